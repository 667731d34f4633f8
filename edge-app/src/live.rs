//! Live SocketCAN: a [`FrameSource`] reading classic and FD frames from a Linux CAN
//! interface (`--can IFACE`), with reconnection, and the bus side of `--publish-id`.
//!
//! ```text
//! open CanFdSocket(IFACE)  (FD mode: classic and FD frames alike)
//!   read with a 100 ms timeout → Frame {ts = the kernel's reception time, id, flags, data}
//!   timeout          → check the stop flag / idle limit, read again
//!   interface down   → close; reopen with backoff 100 ms · 2^k (≤ 5 s), counted
//! stop flag (SIGINT/SIGTERM) → no more frames: the gateway flushes and exits 0
//! ```
//!
//! A frame's time is the kernel's reception time (`SO_TIMESTAMPNS`, as candump's),
//! not the time the gateway reads it: a gateway busy with a window reads the frames
//! that queued meanwhile in one burst, and stamped on reading they would show a
//! silence and a burst that are the gateway's own doing, which the pipeline's clock
//! would read as lost frames. Where the kernel gives no time, the reading time stands
//! in (said once on stderr).
//!
//! Error frames arrive as frames (`FrameKind::Error`) and are counted by the pipeline
//! like every other frame; nothing read is dropped silently.

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use socketcan::{
    CanAnyFrame, CanDataFrame, CanFdSocket, CanFilter, EmbeddedFrame, ExtendedId, Id, ShouldRetry,
    Socket, SocketOptions, StandardId,
};

use crate::candump::{Frame, FrameKind, FrameSource, SourceError};

/// SocketCAN id flag bits (`linux/can.h`).
mod libc_flags {
    /// Extended frame format.
    pub const EFF: u32 = 0x8000_0000;
}

/// First reconnection delay.
pub const BACKOFF_START: Duration = Duration::from_millis(100);
/// Longest reconnection delay.
pub const BACKOFF_MAX: Duration = Duration::from_secs(5);
/// Read timeout: how often the stop flag is looked at while the bus is quiet.
pub const POLL: Duration = Duration::from_millis(100);
/// Socket receive buffer asked for: a burst of ~10 s of a 3-channel 12 kHz bus can
/// queue while a slow gateway catches up, instead of overflowing (the kernel caps it
/// at `net.core.rmem_max`; the size granted is logged).
pub const RECV_BUFFER: usize = 8 << 20;

/// Reads frames from a SocketCAN interface.
#[derive(Debug)]
pub struct SocketCanSource {
    iface: String,
    socket: Option<CanFdSocket>,
    stop: Arc<AtomicBool>,
    idle_limit: Option<Duration>,
    exclude_id: Option<u32>,
    last_frame: Instant,
    backoff: Duration,
    /// Times the interface was (re)opened after the first open.
    pub reconnects: u64,
    opened_once: bool,
    /// The kernel's reception times are on (else frames are stamped when read).
    kernel_time: bool,
}

impl SocketCanSource {
    /// A source on `iface` that ends when `stop` is set, or (if `idle_limit` is given)
    /// when no frame arrived for that long. The interface is opened on the first read,
    /// and reopened with backoff whenever it fails. `exclude_id` (the gateway's own
    /// `--publish-id`) is filtered out in the kernel, so the gateway does not read its
    /// own diagnosis frames back (SocketCAN loops sent frames back to other sockets).
    pub fn new(
        iface: &str,
        stop: Arc<AtomicBool>,
        idle_limit: Option<Duration>,
        exclude_id: Option<u32>,
    ) -> Self {
        Self {
            iface: iface.to_string(),
            socket: None,
            stop,
            idle_limit,
            exclude_id,
            last_frame: Instant::now(),
            backoff: BACKOFF_START,
            reconnects: 0,
            opened_once: false,
            kernel_time: false,
        }
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
            || self
                .idle_limit
                .is_some_and(|l| self.last_frame.elapsed() >= l)
    }

    /// Sleep `d` in short steps, returning early when stopped.
    fn sleep_unless_stopped(&self, d: Duration) {
        let until = Instant::now() + d;
        while !self.stopped() && Instant::now() < until {
            std::thread::sleep(POLL.min(until.saturating_duration_since(Instant::now())));
        }
    }

    fn open(&mut self) -> io::Result<()> {
        let s = CanFdSocket::open(&self.iface)?;
        s.set_read_timeout(POLL)?;
        if let Some(id) = self.exclude_id {
            let (word, mask) = if id <= 0x7FF {
                (id, 0x7FF | libc_flags::EFF)
            } else {
                (id | libc_flags::EFF, 0x1FFF_FFFF | libc_flags::EFF)
            };
            s.set_filters(&[CanFilter::new_inverted(word, mask)])?;
        }
        self.kernel_time = s.set_recv_timestamp(true).is_ok();
        if !self.kernel_time && !self.opened_once {
            eprintln!(
                "pumptwin-edge: {}: no kernel reception times; frames are stamped when read",
                self.iface
            );
        }
        let raw = s.as_raw_socket();
        if raw.set_recv_buffer_size(RECV_BUFFER).is_ok() && !self.opened_once {
            if let Ok(granted) = raw.recv_buffer_size() {
                eprintln!(
                    "pumptwin-edge: {} receive buffer {} KiB",
                    self.iface,
                    granted >> 10
                );
            }
        }
        self.socket = Some(s);
        if self.opened_once {
            self.reconnects += 1;
            eprintln!("pumptwin-edge: {} reopened", self.iface);
        }
        self.opened_once = true;
        self.backoff = BACKOFF_START;
        Ok(())
    }
}

impl FrameSource for SocketCanSource {
    fn next_frame(&mut self) -> Option<Result<Frame, SourceError>> {
        loop {
            if self.stopped() {
                return None;
            }
            let Some(socket) = &self.socket else {
                if let Err(e) = self.open() {
                    eprintln!(
                        "pumptwin-edge: cannot open {}: {e}; retrying in {} ms",
                        self.iface,
                        self.backoff.as_millis()
                    );
                    self.sleep_unless_stopped(self.backoff);
                    self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
                }
                continue;
            };
            let read = if self.kernel_time {
                socket
                    .read_frame_with_timestamps()
                    .map(|(f, t)| (f, t.socket.map(system_us)))
            } else {
                socket.read_frame().map(|f| (f, None))
            };
            match read {
                Ok((f, kernel_us)) => {
                    self.last_frame = Instant::now();
                    let mut frame = to_frame(&f, &self.iface);
                    if let Some(ts_us) = kernel_us {
                        frame.ts_us = ts_us;
                    }
                    return Some(Ok(frame));
                }
                Err(e) if e.should_retry() || e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    eprintln!("pumptwin-edge: reading {}: {e}; reconnecting", self.iface);
                    self.socket = None;
                    self.sleep_unless_stopped(self.backoff);
                    self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
                }
            }
        }
    }
}

fn now_us() -> u64 {
    system_us(SystemTime::now())
}

fn system_us(t: SystemTime) -> u64 {
    t.duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

fn raw_id(id: Id) -> (u32, bool) {
    match id {
        Id::Standard(s) => (u32::from(s.as_raw()), false),
        Id::Extended(e) => (e.as_raw(), true),
    }
}

/// A socketcan frame as the pipeline's [`Frame`], stamped now (the source puts the
/// kernel's reception time in its place where it has it).
pub fn to_frame(f: &CanAnyFrame, iface: &str) -> Frame {
    let mut iface_s = heapless::String::new();
    for c in iface.chars() {
        if iface_s.push(c).is_err() {
            break;
        }
    }
    let mut frame = Frame {
        ts_us: now_us(),
        iface: iface_s,
        id: 0,
        extended: false,
        fd: false,
        fd_flags: 0,
        kind: FrameKind::Data,
        data: heapless::Vec::new(),
    };
    match f {
        CanAnyFrame::Normal(d) => {
            (frame.id, frame.extended) = raw_id(d.id());
            let _ = frame.data.extend_from_slice(d.data());
        }
        CanAnyFrame::Fd(d) => {
            (frame.id, frame.extended) = raw_id(d.id());
            frame.fd = true;
            frame.fd_flags = u8::from(d.is_brs()) | (u8::from(d.is_esi()) << 1);
            let _ = frame.data.extend_from_slice(d.data());
        }
        CanAnyFrame::Remote(r) => {
            (frame.id, frame.extended) = raw_id(r.id());
            frame.kind = FrameKind::Remote {
                dlc: r.dlc().min(8) as u8,
            };
        }
        CanAnyFrame::Error(e) => {
            frame.id = e.error_bits();
            frame.kind = FrameKind::Error;
            let _ = frame.data.extend_from_slice(e.data());
        }
    }
    frame
}

/// Writes diagnosis frames to a SocketCAN interface (`--publish-id`).
#[derive(Debug)]
pub struct BusPublisher {
    socket: CanFdSocket,
    id: Id,
}

impl BusPublisher {
    /// Open `iface` for sending frames with identifier `id` (extended above 0x7FF).
    ///
    /// # Errors
    /// The interface cannot be opened; `id` above 29 bits.
    pub fn open(iface: &str, id: u32) -> io::Result<Self> {
        let id = if id <= 0x7FF {
            StandardId::new(id as u16).map(Id::Standard)
        } else {
            ExtendedId::new(id).map(Id::Extended)
        }
        .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "CAN id above 29 bits"))?;
        Ok(Self {
            socket: CanFdSocket::open(iface)?,
            id,
        })
    }

    /// Send one classic 8-byte frame.
    ///
    /// # Errors
    /// The write failed (e.g. the interface went down).
    pub fn send(&self, payload: &[u8; 8]) -> io::Result<()> {
        let frame = CanDataFrame::new(self.id, payload)
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "bad frame"))?;
        self.socket.write_frame(&frame)
    }
}
