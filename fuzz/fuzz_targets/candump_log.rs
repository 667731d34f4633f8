//! The `candump -l` log parser: the whole input as a log through [`CandumpReplay`]
//! (line reader, length cap, truncated last line), and every parsed frame written
//! back with [`format_line`] and parsed again (it must come back equal).
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_edge::candump::{format_line, parse_line, CandumpReplay, FrameKind, FrameSource};

fuzz_target!(|data: &[u8]| {
    let mut replay = CandumpReplay::new(data);
    let mut items = 0usize;
    while let Some(item) = replay.next_frame() {
        items += 1;
        let Ok(frame) = item else { continue };
        if frame.kind == FrameKind::Error {
            continue; // format_line is the inverse for data and remote frames only
        }
        let line = format_line(&frame);
        let again = parse_line(line.as_bytes())
            .unwrap_or_else(|e| panic!("{line:?} (from {frame:?}) does not parse: {e}"))
            .unwrap_or_else(|| panic!("{line:?} parses to no frame"));
        assert_eq!(again, frame, "{line:?} does not round-trip");
    }
    assert!(items <= replay.lines_read());
});
