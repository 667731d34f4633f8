//! CAN frames from `candump -l` log files, and the [`FrameSource`] trait that every
//! frame source (this replay now, SocketCAN later) implements.
//!
//! One log line per frame (`can-utils` `lib.c` compact format, `candump -l`):
//!
//! ```text
//! (1700000000.123456) can0 123#DEADBEEF           classic, standard id (3 hex digits)
//! (1700000000.123456) can0 12345678#DEADBEEF      classic, extended id (8 hex digits)
//! (1700000000.123456) can0 123#11.22.33           '.' may separate data bytes
//! (1700000000.123456) can0 123#1122334455667788_E classic with len8_dlc 9..F (8 bytes)
//! (1700000000.123456) can0 123##1DEADBEEF         CAN FD: `##`, a flags nibble, 0..64 bytes
//! (1700000000.123456) can0 123#R  / 123#R5        remote frame, optional DLC 0..8
//! (1700000000.123456) can0 20000080#0000000000000000   error frame (CAN_ERR_FLAG set)
//! (1700000000.123456) can0 123#DEADBEEF T         `candump -l -x` appends T (sent) or R
//! ```
//!
//! Blank lines and lines starting with `#` are skipped. Every other line either gives
//! a [`Frame`] or a [`CandumpError`] naming the line and what is wrong with it; the
//! parser never panics, whatever the bytes (it works on bytes, so non-UTF-8 input is
//! a parse error, not an I/O error), and a line longer than [`MAX_LINE_LEN`] is
//! rejected without being held in memory.

use std::io::{self, BufRead};

/// Payload limit of a classic CAN frame.
pub const CAN_MAX_DLEN: usize = 8;
/// Payload limit of a CAN FD frame.
pub const CANFD_MAX_DLEN: usize = 64;
/// Longest Linux interface name (`IFNAMSIZ − 1`).
pub const IFACE_MAX_LEN: usize = 15;
/// Longest line accepted. The longest valid line (20-digit seconds, 9-digit fraction,
/// 15-byte interface, extended FD frame with 64 dot-separated bytes, direction flag)
/// is about 250 bytes.
pub const MAX_LINE_LEN: usize = 512;

/// Largest standard (11-bit) identifier.
pub const SFF_MAX: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const EFF_MAX: u32 = 0x1FFF_FFFF;
/// Error-frame flag in an 8-digit identifier (`CAN_ERR_FLAG`).
const ERR_FLAG: u32 = 0x2000_0000;

/// Payload lengths a CAN FD frame can have.
pub const CANFD_LENGTHS: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];

/// What a frame is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameKind {
    /// A data frame (classic or FD).
    Data,
    /// A remote transmission request: no payload, a requested length `dlc` (0..=8).
    Remote {
        /// Requested data length code.
        dlc: u8,
    },
    /// An error frame (`CAN_ERR_FLAG`); `id` holds the error class bits.
    Error,
}

/// One CAN frame, heap-free (the same type a SocketCAN source will produce).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    /// Reception time, microseconds since the Unix epoch (the log's clock).
    pub ts_us: u64,
    /// Interface name, e.g. `can0`.
    pub iface: heapless::String<16>,
    /// Identifier without flag bits: ≤ 0x7FF standard, ≤ 0x1FFFFFFF extended.
    pub id: u32,
    /// 29-bit (extended) identifier.
    pub extended: bool,
    /// CAN FD frame.
    pub fd: bool,
    /// CAN FD flags nibble (bit 0 BRS, bit 1 ESI); 0 for classic frames.
    pub fd_flags: u8,
    /// Data, remote or error frame.
    pub kind: FrameKind,
    /// Payload: ≤ 8 bytes classic, ≤ 64 FD, empty for remote frames.
    pub data: heapless::Vec<u8, CANFD_MAX_DLEN>,
}

/// What is wrong with one log line.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LineErrorKind {
    /// The line exceeds [`MAX_LINE_LEN`] bytes.
    #[error("line is longer than {max} bytes")]
    TooLong {
        /// The limit.
        max: usize,
    },
    /// The line does not start with `(seconds.fraction)`.
    #[error("missing timestamp: a candump -l line starts with `(seconds.fraction)`")]
    MissingTimestamp,
    /// The timestamp is not `(digits.digits)` or does not fit in microseconds as u64.
    #[error(
        "bad timestamp `{0}`: expected `(seconds.fraction)`, decimal, at most 9 fraction digits"
    )]
    BadTimestamp(String),
    /// Nothing after the timestamp.
    #[error("missing interface name after the timestamp")]
    MissingInterface,
    /// Interface name longer than [`IFACE_MAX_LEN`] or not printable ASCII.
    #[error("interface name `{0}` is not 1-{IFACE_MAX_LEN} printable ASCII characters")]
    BadInterface(String),
    /// Nothing after the interface name.
    #[error("missing frame after the interface name")]
    MissingFrame,
    /// The frame field has no `#`.
    #[error("frame `{0}` has no `#` between identifier and data")]
    MissingSeparator(String),
    /// The identifier is neither 3 nor 8 hex digits.
    #[error("identifier `{0}` must be 3 hex digits (standard) or 8 (extended)")]
    BadIdLength(String),
    /// The identifier has a non-hex character.
    #[error("identifier `{0}` is not hexadecimal")]
    BadIdHex(String),
    /// A 3-digit identifier above 0x7FF.
    #[error("standard identifier {0:#05x} exceeds 0x7FF")]
    StandardIdRange(u32),
    /// An 8-digit identifier with flag bits other than the error flag.
    #[error("extended identifier {0:#010x} exceeds 0x1FFFFFFF")]
    ExtendedIdRange(u32),
    /// A non-hex character in the data at this (0-based) character offset.
    #[error("data character {offset} is not a hex digit or `.` between bytes")]
    BadDataHex {
        /// Offset into the data field.
        offset: usize,
    },
    /// A byte with only one hex digit.
    #[error("data ends in half a byte (odd number of hex digits)")]
    OddDataDigits,
    /// More payload than the frame type carries.
    #[error("{got} data bytes exceed the maximum of {max}")]
    TooMuchData {
        /// Bytes found (stops counting at max + 1).
        got: usize,
        /// The limit (8 classic, 64 FD).
        max: usize,
    },
    /// `##` not followed by the flags nibble.
    #[error("CAN FD frame has no flags nibble after `##`")]
    MissingFdFlags,
    /// The CAN FD flags are not one hex digit.
    #[error("CAN FD flags `{0}` are not a hex digit")]
    BadFdFlags(char),
    /// A CAN FD payload length a CAN FD frame cannot have.
    #[error(
        "CAN FD frame has {0} data bytes, not a CAN FD length (0-8, 12, 16, 20, 24, 32, 48, 64)"
    )]
    BadFdLength(usize),
    /// `R` followed by something other than one digit 0..8.
    #[error("remote frame `R{0}`: the DLC after R must be one digit 0-8")]
    BadRemoteDlc(String),
    /// A `_X` suffix that is not one hex digit 9..F after exactly 8 classic bytes.
    #[error("len8_dlc suffix `_{0}` is only valid after 8 data bytes and must be 9-F")]
    BadLen8Dlc(String),
    /// An error frame written as CAN FD or remote.
    #[error("an error frame (CAN_ERR_FLAG) must be a classic data frame")]
    ErrorFrameNotClassic,
    /// More fields after the frame than the optional direction flag.
    #[error("unexpected `{0}` after the frame (only a direction flag T or R may follow)")]
    TrailingField(String),
}

/// A log line that is not a frame, with its 1-based line number.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("candump line {line}: {kind}")]
pub struct CandumpError {
    /// 1-based line number in the log.
    pub line: usize,
    /// What is wrong.
    pub kind: LineErrorKind,
}

/// Why a [`FrameSource`] could not deliver a frame.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// A line of a candump log is not a frame; the source can go on with the next line.
    #[error(transparent)]
    Parse(#[from] CandumpError),
    /// Reading failed; the source is finished.
    #[error("reading frames: {0}")]
    Io(#[from] io::Error),
}

impl SourceError {
    /// Whether the source can deliver more frames after this error (a bad line: yes;
    /// an I/O failure: no).
    pub fn is_recoverable(&self) -> bool {
        matches!(self, SourceError::Parse(_))
    }
}

/// Anything that delivers CAN frames in arrival order: a candump replay
/// ([`CandumpReplay`]), a SocketCAN socket (a later issue), a scripted bus in tests.
pub trait FrameSource {
    /// The next frame, an error, or `None` when the source is exhausted. After a
    /// non-recoverable error ([`SourceError::is_recoverable`]) the source returns `None`.
    fn next_frame(&mut self) -> Option<Result<Frame, SourceError>>;
}

/// Replays a `candump -l` log from any [`BufRead`], one frame per call.
#[derive(Debug)]
pub struct CandumpReplay<R> {
    reader: R,
    line: Vec<u8>,
    line_no: usize,
    done: bool,
}

impl<R: BufRead> CandumpReplay<R> {
    /// Replay from `reader`.
    pub fn new(reader: R) -> Self {
        Self {
            reader,
            line: Vec::with_capacity(MAX_LINE_LEN),
            line_no: 0,
            done: false,
        }
    }

    /// Number of lines read so far.
    pub fn lines_read(&self) -> usize {
        self.line_no
    }

    /// Read one line into `self.line` (without the newline), keeping at most
    /// `MAX_LINE_LEN + 1` bytes of it. `Ok(false)` at end of input.
    fn read_line(&mut self) -> io::Result<bool> {
        self.line.clear();
        let mut any = false;
        loop {
            let buf = match self.reader.fill_buf() {
                Ok(b) => b,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if buf.is_empty() {
                return Ok(any);
            }
            any = true;
            let (chunk, used, end) = match buf.iter().position(|&b| b == b'\n') {
                Some(i) => (&buf[..i], i + 1, true),
                None => (buf, buf.len(), false),
            };
            let room = (MAX_LINE_LEN + 1).saturating_sub(self.line.len());
            self.line.extend_from_slice(&chunk[..chunk.len().min(room)]);
            self.reader.consume(used);
            if end {
                return Ok(true);
            }
        }
    }
}

impl<R: BufRead> FrameSource for CandumpReplay<R> {
    fn next_frame(&mut self) -> Option<Result<Frame, SourceError>> {
        while !self.done {
            match self.read_line() {
                Ok(false) => self.done = true,
                Ok(true) => {
                    self.line_no += 1;
                    match parse_line(&self.line) {
                        Ok(None) => continue,
                        Ok(Some(frame)) => return Some(Ok(frame)),
                        Err(kind) => {
                            return Some(Err(CandumpError {
                                line: self.line_no,
                                kind,
                            }
                            .into()))
                        }
                    }
                }
                Err(e) => {
                    self.done = true;
                    return Some(Err(e.into()));
                }
            }
        }
        None
    }
}

/// Parse one log line (without its newline; a trailing `\r` is ignored).
/// `Ok(None)` for a blank line or a `#` comment.
pub fn parse_line(line: &[u8]) -> Result<Option<Frame>, LineErrorKind> {
    if line.len() > MAX_LINE_LEN {
        return Err(LineErrorKind::TooLong { max: MAX_LINE_LEN });
    }
    let line = line.trim_ascii();
    if line.is_empty() || line.first() == Some(&b'#') {
        return Ok(None);
    }
    let mut fields = line
        .split(|b| b.is_ascii_whitespace())
        .filter(|f| !f.is_empty());
    let ts = fields.next().ok_or(LineErrorKind::MissingTimestamp)?;
    if ts.first() != Some(&b'(') {
        return Err(LineErrorKind::MissingTimestamp);
    }
    let ts_us = parse_timestamp(ts).ok_or_else(|| LineErrorKind::BadTimestamp(snippet(ts)))?;
    let iface_field = fields.next().ok_or(LineErrorKind::MissingInterface)?;
    let mut iface = heapless::String::<16>::new();
    let printable =
        iface_field.len() <= IFACE_MAX_LEN && iface_field.iter().all(|b| b.is_ascii_graphic());
    let pushed =
        printable && std::str::from_utf8(iface_field).is_ok_and(|s| iface.push_str(s).is_ok());
    if !pushed {
        return Err(LineErrorKind::BadInterface(snippet(iface_field)));
    }
    let frame_field = fields.next().ok_or(LineErrorKind::MissingFrame)?;
    if let Some(extra) = fields.next() {
        if !(extra == b"T" || extra == b"R") {
            return Err(LineErrorKind::TrailingField(snippet(extra)));
        }
        if let Some(more) = fields.next() {
            return Err(LineErrorKind::TrailingField(snippet(more)));
        }
    }
    let mut frame = parse_frame(frame_field)?;
    frame.ts_us = ts_us;
    frame.iface = iface;
    Ok(Some(frame))
}

/// `(seconds.fraction)` → microseconds (fraction digits past the sixth truncated).
fn parse_timestamp(field: &[u8]) -> Option<u64> {
    let inner = field.strip_prefix(b"(")?.strip_suffix(b")")?;
    let dot = inner.iter().position(|&b| b == b'.')?;
    let (sec, frac) = (&inner[..dot], &inner[dot + 1..]);
    if sec.is_empty() || sec.len() > 20 || frac.is_empty() || frac.len() > 9 {
        return None;
    }
    let sec = parse_decimal(sec)?;
    let mut frac_us = parse_decimal(frac)?;
    if frac.len() <= 6 {
        frac_us *= 10u64.pow(6 - frac.len() as u32);
    } else {
        frac_us /= 10u64.pow(frac.len() as u32 - 6);
    }
    sec.checked_mul(1_000_000)?.checked_add(frac_us)
}

fn parse_decimal(digits: &[u8]) -> Option<u64> {
    digits.iter().try_fold(0u64, |acc, &b| {
        let d = (b as char).to_digit(10)?;
        acc.checked_mul(10)?.checked_add(u64::from(d))
    })
}

fn hex_value(b: u8) -> Option<u8> {
    (b as char).to_digit(16).map(|d| d as u8)
}

/// `ID#DATA`, `ID##FDATA`, `ID#R[dlc]` → a frame with `ts_us = 0` and no interface.
fn parse_frame(field: &[u8]) -> Result<Frame, LineErrorKind> {
    let hash = field
        .iter()
        .position(|&b| b == b'#')
        .ok_or_else(|| LineErrorKind::MissingSeparator(snippet(field)))?;
    let (id_text, rest) = (&field[..hash], &field[hash + 1..]);
    let raw_id = id_text
        .iter()
        .try_fold(0u32, |acc, &b| Some((acc << 4) | u32::from(hex_value(b)?)));
    let (id, extended, error) = match (id_text.len(), raw_id) {
        (3 | 8, None) => return Err(LineErrorKind::BadIdHex(snippet(id_text))),
        (3, Some(v)) if v > SFF_MAX => return Err(LineErrorKind::StandardIdRange(v)),
        (3, Some(v)) => (v, false, false),
        (8, Some(v)) if v & !(EFF_MAX | ERR_FLAG) != 0 => {
            return Err(LineErrorKind::ExtendedIdRange(v))
        }
        (8, Some(v)) => (v & EFF_MAX, true, v & ERR_FLAG != 0),
        _ => return Err(LineErrorKind::BadIdLength(snippet(id_text))),
    };
    let mut frame = Frame {
        ts_us: 0,
        iface: heapless::String::new(),
        id,
        extended,
        fd: false,
        fd_flags: 0,
        kind: if error {
            FrameKind::Error
        } else {
            FrameKind::Data
        },
        data: heapless::Vec::new(),
    };
    match rest.first() {
        Some(b'#') => {
            if error {
                return Err(LineErrorKind::ErrorFrameNotClassic);
            }
            let flags = *rest.get(1).ok_or(LineErrorKind::MissingFdFlags)?;
            frame.fd = true;
            frame.fd_flags =
                hex_value(flags).ok_or(LineErrorKind::BadFdFlags(char::from(flags)))?;
            let (data, suffix) = parse_data(rest.get(2..).unwrap_or(&[]), CANFD_MAX_DLEN)?;
            if let Some(s) = suffix {
                return Err(LineErrorKind::BadLen8Dlc(snippet(s)));
            }
            if !CANFD_LENGTHS.contains(&data.len()) {
                return Err(LineErrorKind::BadFdLength(data.len()));
            }
            frame.data = data;
        }
        Some(b'R' | b'r') => {
            if error {
                return Err(LineErrorKind::ErrorFrameNotClassic);
            }
            let dlc = match rest.get(1..).unwrap_or(&[]) {
                [] => 0,
                [d @ b'0'..=b'8'] => d - b'0',
                other => return Err(LineErrorKind::BadRemoteDlc(snippet(other))),
            };
            frame.kind = FrameKind::Remote { dlc };
        }
        _ => {
            let (data, suffix) = parse_data(rest, CAN_MAX_DLEN)?;
            if let Some(s) = suffix {
                let ok = data.len() == CAN_MAX_DLEN
                    && matches!(s, [d] if hex_value(*d).is_some_and(|v| v >= 9));
                if !ok {
                    return Err(LineErrorKind::BadLen8Dlc(snippet(s)));
                }
            }
            frame.data = data;
        }
    }
    Ok(frame)
}

type Payload = heapless::Vec<u8, CANFD_MAX_DLEN>;

/// Hex byte pairs, optionally separated by `.`, at most `max` bytes; stops at `_` and
/// returns what follows it as the len8_dlc suffix.
fn parse_data(text: &[u8], max: usize) -> Result<(Payload, Option<&[u8]>), LineErrorKind> {
    let mut data = Payload::new();
    let mut i = 0;
    while let Some(&c) = text.get(i) {
        match c {
            b'.' => i += 1,
            b'_' => return Ok((data, Some(text.get(i + 1..).unwrap_or(&[])))),
            _ => {
                let hi = hex_value(c).ok_or(LineErrorKind::BadDataHex { offset: i })?;
                let lo_char = *text.get(i + 1).ok_or(LineErrorKind::OddDataDigits)?;
                let lo = match hex_value(lo_char) {
                    Some(v) => v,
                    None if lo_char == b'.' || lo_char == b'_' => {
                        return Err(LineErrorKind::OddDataDigits)
                    }
                    None => return Err(LineErrorKind::BadDataHex { offset: i + 1 }),
                };
                if data.len() >= max || data.push((hi << 4) | lo).is_err() {
                    return Err(LineErrorKind::TooMuchData { got: max + 1, max });
                }
                i += 2;
            }
        }
    }
    Ok((data, None))
}

/// At most 32 characters of a field, for error messages.
fn snippet(bytes: &[u8]) -> String {
    let cut = &bytes[..bytes.len().min(32)];
    let mut s = String::from_utf8_lossy(cut).into_owned();
    if bytes.len() > cut.len() {
        s.push('…');
    }
    s
}

/// One frame as a `candump -l` line (no newline): the inverse of [`parse_line`] for
/// data and remote frames. Used to write logs (and by tests to round-trip).
pub fn format_line(frame: &Frame) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(64 + 3 * frame.data.len());
    let _ = write!(
        s,
        "({}.{:06}) {} ",
        frame.ts_us / 1_000_000,
        frame.ts_us % 1_000_000,
        frame.iface
    );
    let id = if frame.kind == FrameKind::Error {
        frame.id | ERR_FLAG
    } else {
        frame.id
    };
    if frame.extended || frame.kind == FrameKind::Error {
        let _ = write!(s, "{id:08X}");
    } else {
        let _ = write!(s, "{id:03X}");
    }
    match frame.kind {
        FrameKind::Remote { dlc } => {
            s.push_str("#R");
            if dlc > 0 {
                let _ = write!(s, "{dlc}");
            }
        }
        _ if frame.fd => {
            let _ = write!(s, "##{:X}", frame.fd_flags & 0xF);
        }
        _ => s.push('#'),
    }
    for b in &frame.data {
        let _ = write!(s, "{b:02X}");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(line: &str) -> Frame {
        parse_line(line.as_bytes())
            .unwrap_or_else(|e| panic!("{line}: {e}"))
            .unwrap_or_else(|| panic!("{line}: skipped"))
    }

    fn error(line: &str) -> LineErrorKind {
        match parse_line(line.as_bytes()) {
            Err(e) => e,
            Ok(f) => panic!("{line}: parsed as {f:?}"),
        }
    }

    #[test]
    fn classic_standard_and_extended() {
        let f = frame("(1700000000.123456) can0 123#DEADBEEF");
        assert_eq!(f.ts_us, 1_700_000_000_123_456);
        assert_eq!(f.iface.as_str(), "can0");
        assert_eq!((f.id, f.extended, f.fd), (0x123, false, false));
        assert_eq!(f.kind, FrameKind::Data);
        assert_eq!(f.data.as_slice(), &[0xDE, 0xAD, 0xBE, 0xEF]);

        let f = frame("(0.5)   vcan12 1FFFFFFF#0011223344556677");
        assert_eq!((f.ts_us, f.id, f.extended), (500_000, 0x1FFF_FFFF, true));
        assert_eq!(f.data.len(), 8);
        // Leading zeros in an 8-digit id still mean extended.
        let f = frame("(1.000001) can0 00000123#");
        assert_eq!((f.id, f.extended, f.data.len()), (0x123, true, 0));
    }

    #[test]
    fn separators_len8_dlc_direction_and_whitespace() {
        let f = frame("(1.000000) can0 123#11.22.33\r");
        assert_eq!(f.data.as_slice(), &[0x11, 0x22, 0x33]);
        let f = frame("(1.000000) can0 123#1122334455667788_E");
        assert_eq!(f.data.len(), 8);
        let f = frame("  (1.000000)\t can0   7FF#aa T ");
        assert_eq!((f.id, f.data.as_slice()), (0x7FF, &[0xAA][..]));
        assert!(frame("(1.000000) can0 123#aa R").data.len() == 1);
        // Fraction digits beyond microseconds are truncated; fewer are scaled.
        assert_eq!(frame("(2.123456789) can0 123#").ts_us, 2_123_456);
        assert_eq!(frame("(2.5) can0 123#").ts_us, 2_500_000);
    }

    #[test]
    fn can_fd_frames() {
        let f = frame("(1.000000) can0 123##1DEADBEEF");
        assert!(f.fd);
        assert_eq!(f.fd_flags, 1);
        assert_eq!(f.data.as_slice(), &[0xDE, 0xAD, 0xBE, 0xEF]);
        let long = format!("(1.000000) can1 12345678##3{}", "AB".repeat(64));
        let f = frame(&long);
        assert_eq!(
            (f.id, f.extended, f.fd_flags, f.data.len()),
            (0x1234_5678, true, 3, 64)
        );
        assert!(frame("(1.000000) can0 123##0").data.is_empty());
    }

    #[test]
    fn remote_and_error_frames() {
        let f = frame("(1.000000) can0 123#R");
        assert_eq!(f.kind, FrameKind::Remote { dlc: 0 });
        assert!(f.data.is_empty());
        assert_eq!(
            frame("(1.000000) can0 12345678#R5").kind,
            FrameKind::Remote { dlc: 5 }
        );
        let f = frame("(1.000000) can0 20000080#0000000000000000");
        assert_eq!((f.kind, f.id), (FrameKind::Error, 0x80));
    }

    #[test]
    fn blank_and_comment_lines_are_skipped() {
        for line in [
            "",
            "   ",
            "\r",
            "# a comment",
            "  # indented comment (1.0) can0 123#",
        ] {
            assert_eq!(parse_line(line.as_bytes()), Ok(None), "{line:?}");
        }
    }

    type Check = fn(&LineErrorKind) -> bool;

    #[test]
    fn every_malformed_variant_is_an_error() {
        use LineErrorKind as K;
        let cases: &[(&str, Check)] = &[
            ("can0 123#00", |e| *e == K::MissingTimestamp),
            ("(1.000000)", |e| *e == K::MissingInterface),
            ("(1.000000) can0", |e| *e == K::MissingFrame),
            ("(1.0000000000) can0 123#", |e| {
                matches!(e, K::BadTimestamp(_))
            }),
            ("(1) can0 123#", |e| matches!(e, K::BadTimestamp(_))),
            ("(.5) can0 123#", |e| matches!(e, K::BadTimestamp(_))),
            ("(1.) can0 123#", |e| matches!(e, K::BadTimestamp(_))),
            ("(1.000000 can0 123#", |e| matches!(e, K::BadTimestamp(_))),
            ("(1.0x0000) can0 123#", |e| matches!(e, K::BadTimestamp(_))),
            ("(-1.000000) can0 123#", |e| matches!(e, K::BadTimestamp(_))),
            ("(99999999999999999999.0) can0 123#", |e| {
                matches!(e, K::BadTimestamp(_))
            }),
            ("(1.0) averyveryverylongname0 123#", |e| {
                matches!(e, K::BadInterface(_))
            }),
            ("(1.0) can0 123", |e| matches!(e, K::MissingSeparator(_))),
            ("(1.0) can0 12#00", |e| matches!(e, K::BadIdLength(_))),
            ("(1.0) can0 1234#00", |e| matches!(e, K::BadIdLength(_))),
            ("(1.0) can0 #00", |e| matches!(e, K::BadIdLength(_))),
            ("(1.0) can0 12G#00", |e| matches!(e, K::BadIdHex(_))),
            ("(1.0) can0 800#00", |e| *e == K::StandardIdRange(0x800)),
            ("(1.0) can0 40000000#00", |e| {
                *e == K::ExtendedIdRange(0x4000_0000)
            }),
            ("(1.0) can0 123#0G", |e| *e == K::BadDataHex { offset: 1 }),
            ("(1.0) can0 123#G0", |e| *e == K::BadDataHex { offset: 0 }),
            ("(1.0) can0 123#ABC", |e| *e == K::OddDataDigits),
            ("(1.0) can0 123#A.BC", |e| *e == K::OddDataDigits),
            ("(1.0) can0 123#001122334455667788", |e| {
                *e == K::TooMuchData { got: 9, max: 8 }
            }),
            ("(1.0) can0 123##", |e| *e == K::MissingFdFlags),
            ("(1.0) can0 123##X00", |e| *e == K::BadFdFlags('X')),
            ("(1.0) can0 123##0001122334455667788", |e| {
                *e == K::BadFdLength(9)
            }),
            ("(1.0) can0 123#R9", |e| matches!(e, K::BadRemoteDlc(_))),
            ("(1.0) can0 123#R12", |e| matches!(e, K::BadRemoteDlc(_))),
            ("(1.0) can0 123##R", |e| *e == K::BadFdFlags('R')),
            ("(1.0) can0 123#11_E", |e| matches!(e, K::BadLen8Dlc(_))),
            ("(1.0) can0 123#1122334455667788_8", |e| {
                matches!(e, K::BadLen8Dlc(_))
            }),
            ("(1.0) can0 123#1122334455667788_EE", |e| {
                matches!(e, K::BadLen8Dlc(_))
            }),
            ("(1.0) can0 123##01122_E", |e| matches!(e, K::BadLen8Dlc(_))),
            ("(1.0) can0 20000080##000", |e| {
                *e == K::ErrorFrameNotClassic
            }),
            ("(1.0) can0 20000080#R", |e| *e == K::ErrorFrameNotClassic),
            ("(1.0) can0 123#00 X", |e| matches!(e, K::TrailingField(_))),
            ("(1.0) can0 123#00 T extra", |e| {
                matches!(e, K::TrailingField(_))
            }),
        ];
        for (line, check) in cases {
            let e = error(line);
            assert!(check(&e), "{line}: {e}");
            assert!(!e.to_string().is_empty());
        }
        let long = format!("(1.0) can0 123#{}", "0".repeat(MAX_LINE_LEN));
        assert_eq!(error(&long), K::TooLong { max: MAX_LINE_LEN });
        assert!(matches!(
            parse_line(b"(1.0) can\xff0 123#00"),
            Err(K::BadInterface(_))
        ));
    }

    /// xorshift64 (Marsaglia 2003): a fixed-seed byte source for the fuzz loop.
    struct XorShift(u64);
    impl XorShift {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
    }

    /// 10 000 random lines: random bytes, random picks from the grammar's alphabet,
    /// and mutations of valid lines. Every one is a frame, a skip or an error.
    #[test]
    fn fuzz_random_lines_never_panic() {
        let mut rng = XorShift(0x9E37_79B9_7F4A_7C15);
        let alphabet = b"()#.R_rTx 0123456789abcdefABCDEFGcan\t\r-";
        let seeds = [
            "(1700000000.123456) can0 123#DEADBEEF",
            "(1700000000.123456) can0 12345678##1DEADBEEF0011223344",
            "(1.000000) vcan0 123#R5",
            "(1.000000) can0 20000080#0000000000000000 R",
            "(1.000000) can0 123#1122334455667788_E",
        ];
        let (mut frames, mut errors, mut skipped) = (0, 0, 0);
        for i in 0..10_000 {
            let line: Vec<u8> = match i % 3 {
                0 => (0..rng.below(80)).map(|_| rng.next() as u8).collect(),
                1 => (0..rng.below(120))
                    .map(|_| alphabet[rng.below(alphabet.len())])
                    .collect(),
                _ => {
                    let mut l = seeds[rng.below(seeds.len())].as_bytes().to_vec();
                    for _ in 0..1 + rng.below(4) {
                        let at = rng.below(l.len() + 1);
                        match rng.below(3) {
                            0 if at < l.len() => {
                                l.remove(at);
                            }
                            1 if at < l.len() => l[at] = alphabet[rng.below(alphabet.len())],
                            _ => l.insert(at, alphabet[rng.below(alphabet.len())]),
                        }
                    }
                    l
                }
            };
            match parse_line(&line) {
                Ok(Some(f)) => {
                    frames += 1;
                    assert!(f.data.len() <= if f.fd { 64 } else { 8 });
                    assert!(f.id <= if f.extended { EFF_MAX } else { SFF_MAX });
                }
                Ok(None) => skipped += 1,
                Err(e) => {
                    errors += 1;
                    assert!(!e.to_string().is_empty());
                }
            }
        }
        // The mix reaches all three outcomes.
        assert!(
            frames > 100 && errors > 1000 && skipped > 0,
            "{frames} {errors} {skipped}"
        );
    }

    #[test]
    fn format_line_round_trips() {
        for line in [
            "(1700000000.123456) can0 123#DEADBEEF",
            "(0.000001) can1 1ABCDEF0#",
            "(5.000000) can0 123##1DEADBEEF",
            "(5.000000) can0 7FF#R3",
            "(5.000000) can0 20000080#0000000000000000",
        ] {
            let f = frame(line);
            assert_eq!(format_line(&f), line);
            assert_eq!(frame(&format_line(&f)), f);
        }
    }

    #[test]
    fn replay_numbers_lines_and_goes_on_after_bad_ones() {
        let log = "# recorded on the test bench\n\
                   (1.000000) can0 123#00\n\
                   \n\
                   (1.000100) can0 12#00\n\
                   (1.000200) can0 124#0102";
        let mut src = CandumpReplay::new(log.as_bytes());
        assert_eq!(src.next_frame().unwrap().unwrap().id, 0x123);
        match src.next_frame().unwrap() {
            Err(SourceError::Parse(e)) => {
                assert_eq!(e.line, 4);
                assert!(e.to_string().starts_with("candump line 4:"), "{e}");
            }
            other => panic!("{other:?}"),
        }
        let f = src.next_frame().unwrap().unwrap();
        assert_eq!((f.id, f.data.len()), (0x124, 2));
        assert!(src.next_frame().is_none());
        assert!(src.next_frame().is_none());
        assert_eq!(src.lines_read(), 5);
    }

    #[test]
    fn replay_bounds_an_endless_line() {
        let mut log = vec![b'A'; 100_000];
        log.extend_from_slice(b"\n(1.0) can0 123#00\n");
        // A tiny buffer forces the long line through many fill_buf calls.
        let mut src = CandumpReplay::new(io::BufReader::with_capacity(7, log.as_slice()));
        match src.next_frame().unwrap() {
            Err(SourceError::Parse(e)) => {
                assert_eq!(e.kind, LineErrorKind::TooLong { max: MAX_LINE_LEN })
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(src.next_frame().unwrap().unwrap().id, 0x123);
        assert!(src.next_frame().is_none());
    }

    #[test]
    fn replay_stops_after_an_io_error() {
        struct Failing;
        impl io::Read for Failing {
            fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
                Err(io::Error::other("disk gone"))
            }
        }
        let mut src = CandumpReplay::new(io::BufReader::new(Failing));
        let e = src.next_frame().unwrap().unwrap_err();
        assert!(!e.is_recoverable());
        assert!(src.next_frame().is_none());
    }
}
