//! Telemetry to an MQTT broker (`--mqtt URL --topic-prefix P`) with store-and-forward.
//!
//! ```text
//! window line ──► seq n, appended to the on-disk queue (DIR/queue.log, fsync'd per line)
//!                 └─ queue over capacity → the oldest unacknowledged entry is dropped, counted
//! sender thread: connected → publish queued entries in order, QoS 1, ≤ INFLIGHT at once
//!                PUBACK    → entry acknowledged; the acknowledged prefix goes to DIR/acked
//!                error     → drop the connection; every unacknowledged entry is sent
//!                            again after the reconnect (backoff 100 ms · 2^k ≤ 5 s)
//! restart of the gateway → the queue is read back, entries after DIR/acked are sent
//! ```
//!
//! Topics: `P/diagnosis` (every window line, with `"seq"` added first) and `P/health`
//! (the counters every [`HEALTH_EVERY`] windows). QoS 1 is at-least-once on the wire: an
//! entry whose PUBACK was lost in a broker restart is sent again, so a consumer
//! deduplicates by `seq`; every `seq` produced arrives (at least once) or is counted in
//! `dropped`. The counts (`produced = delivered + dropped + pending`) are printed at the
//! end of a run, after the sender drained the queue (or gave up after the drain timeout).

use std::collections::VecDeque;
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rumqttc::{
    Client, Connection, Event, MqttOptions, Outgoing, Packet, QoS, RecvTimeoutError, Transport,
};

/// Unacknowledged publishes on the wire at once.
pub const INFLIGHT: usize = 32;
/// A health message every this many windows.
pub const HEALTH_EVERY: u64 = 100;

/// Where and how to publish.
#[derive(Debug, Clone)]
pub struct MqttConfig {
    /// `mqtt://host[:port]` (1883) or `mqtts://host[:port]` (8883, TLS).
    pub url: String,
    /// Topic prefix `P`.
    pub topic_prefix: String,
    /// Client id.
    pub client_id: String,
    /// Username and password, if the broker wants them.
    pub credentials: Option<(String, String)>,
    /// CA certificate (PEM) for `mqtts://`.
    pub ca_file: Option<PathBuf>,
    /// Queue directory.
    pub queue_dir: PathBuf,
    /// Most entries the queue keeps.
    pub capacity: usize,
    /// How long the end of a run waits for the queue to drain.
    pub drain_timeout: Duration,
}

/// What happened to the entries.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MqttStats {
    /// Entries produced (enqueued) in this run, plus those read back from the queue.
    pub produced: u64,
    /// Acknowledged by the broker.
    pub delivered: u64,
    /// Dropped because the queue was full.
    pub dropped: u64,
    /// Still queued at the end.
    pub pending: u64,
    /// Publishes sent again after a connection loss.
    pub resent: u64,
    /// Connections made.
    pub connects: u64,
}

/// Why the MQTT configuration was refused.
#[derive(Debug, thiserror::Error)]
pub enum MqttError {
    /// Not `mqtt://host[:port]` or `mqtts://host[:port]`.
    #[error("bad MQTT URL {0:?}: expected mqtt://host[:port] or mqtts://host[:port]")]
    Url(String),
    /// The queue directory or files.
    #[error("MQTT queue in {path}: {source}")]
    Queue {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

struct Entry {
    seq: u64,
    topic: String,
    payload: String,
    /// Published at least once in this run (a later publish counts as resent).
    sent: bool,
}

/// The on-disk queue: `queue.log` holds `seq\ttopic\tpayload` lines, `acked` the
/// highest sequence number below which everything is acknowledged or dropped.
struct DiskQueue {
    dir: PathBuf,
    log: File,
    entries: VecDeque<Entry>,
    /// Everything below this is acknowledged or dropped.
    done_below: u64,
    next_seq: u64,
    lines_in_file: usize,
}

impl DiskQueue {
    fn open(dir: &Path) -> Result<Self, MqttError> {
        let err = |path: &Path| {
            let path = path.to_owned();
            move |source| MqttError::Queue { path, source }
        };
        std::fs::create_dir_all(dir).map_err(err(dir))?;
        let acked_path = dir.join("acked");
        let done_below = std::fs::read_to_string(&acked_path)
            .ok()
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(0);
        let log_path = dir.join("queue.log");
        let mut entries = VecDeque::new();
        let mut lines_in_file = 0;
        let mut next_seq = done_below;
        if let Ok(f) = File::open(&log_path) {
            for line in BufReader::new(f).lines() {
                let line = line.map_err(err(&log_path))?;
                lines_in_file += 1;
                let mut parts = line.splitn(3, '\t');
                let (Some(seq), Some(topic), Some(payload)) =
                    (parts.next(), parts.next(), parts.next())
                else {
                    continue; // a torn last line after a crash: never acknowledged
                };
                let Ok(seq) = seq.parse::<u64>() else {
                    continue;
                };
                next_seq = next_seq.max(seq + 1);
                if seq >= done_below {
                    entries.push_back(Entry {
                        seq,
                        topic: topic.to_string(),
                        payload: payload.to_string(),
                        sent: false,
                    });
                }
            }
        }
        let log = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log_path)
            .map_err(err(&log_path))?;
        Ok(Self {
            dir: dir.to_owned(),
            log,
            entries,
            done_below,
            next_seq,
            lines_in_file,
        })
    }

    fn push(&mut self, topic: String, payload: String) -> std::io::Result<u64> {
        let seq = self.next_seq;
        self.next_seq += 1;
        writeln!(self.log, "{seq}\t{topic}\t{payload}")?;
        self.log.sync_data()?;
        self.lines_in_file += 1;
        self.entries.push_back(Entry {
            seq,
            topic,
            payload,
            sent: false,
        });
        Ok(seq)
    }

    /// Mark `seq` done (acknowledged or dropped) and persist the done prefix.
    fn done(&mut self, seq: u64) -> std::io::Result<()> {
        if let Some(pos) = self.entries.iter().position(|e| e.seq == seq) {
            self.entries.remove(pos);
        }
        let below = self.entries.front().map_or(self.next_seq, |e| e.seq);
        if below != self.done_below {
            self.done_below = below;
            let tmp = self.dir.join("acked.tmp");
            std::fs::write(&tmp, format!("{below}\n"))?;
            std::fs::rename(&tmp, self.dir.join("acked"))?;
        }
        if self.lines_in_file > 4 * self.entries.len().max(256) {
            self.compact()?;
        }
        Ok(())
    }

    /// Rewrite `queue.log` with the entries still queued.
    fn compact(&mut self) -> std::io::Result<()> {
        let tmp = self.dir.join("queue.log.tmp");
        let mut f = File::create(&tmp)?;
        for e in &self.entries {
            writeln!(f, "{}\t{}\t{}", e.seq, e.topic, e.payload)?;
        }
        f.sync_all()?;
        std::fs::rename(&tmp, self.dir.join("queue.log"))?;
        self.log = OpenOptions::new()
            .append(true)
            .open(self.dir.join("queue.log"))?;
        self.lines_in_file = self.entries.len();
        Ok(())
    }
}

enum Msg {
    Publish { topic: String, payload: String },
    Finish,
}

/// The publishing side: hand lines to [`MqttSink::send_window`], then
/// [`MqttSink::finish`] to drain and get the counts.
pub struct MqttSink {
    tx: Sender<Msg>,
    handle: Option<JoinHandle<MqttStats>>,
    prefix: String,
    windows: u64,
}

impl std::fmt::Debug for MqttSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MqttSink")
            .field("prefix", &self.prefix)
            .field("windows", &self.windows)
            .finish_non_exhaustive()
    }
}

fn parse_url(url: &str) -> Result<(String, u16, bool), MqttError> {
    let bad = || MqttError::Url(url.to_string());
    let (rest, tls) = if let Some(r) = url.strip_prefix("mqtt://") {
        (r, false)
    } else if let Some(r) = url.strip_prefix("mqtts://") {
        (r, true)
    } else {
        return Err(bad());
    };
    let rest = rest.trim_end_matches('/');
    let (host, port) = match rest.rsplit_once(':') {
        Some((h, p)) => (h, p.parse::<u16>().map_err(|_| bad())?),
        None => (rest, if tls { 8883 } else { 1883 }),
    };
    if host.is_empty() {
        return Err(bad());
    }
    Ok((host.to_string(), port, tls))
}

impl MqttSink {
    /// Open the queue (reading back what a previous run left) and start the sender.
    ///
    /// # Errors
    /// A bad URL, an unreadable CA file, a queue directory that cannot be used.
    pub fn start(cfg: MqttConfig) -> Result<Self, MqttError> {
        let (host, port, tls) = parse_url(&cfg.url)?;
        let mut opts = MqttOptions::new(cfg.client_id.clone(), host, port);
        opts.set_keep_alive(Duration::from_secs(5));
        opts.set_inflight(INFLIGHT as u16);
        if let Some((u, p)) = &cfg.credentials {
            opts.set_credentials(u.clone(), p.clone());
        }
        if tls {
            let ca = match &cfg.ca_file {
                Some(p) => std::fs::read(p).map_err(|source| MqttError::Queue {
                    path: p.clone(),
                    source,
                })?,
                None => Vec::new(),
            };
            opts.set_transport(Transport::tls(ca, None, None));
        }
        let queue = DiskQueue::open(&cfg.queue_dir)?;
        let (tx, rx) = mpsc::channel();
        let prefix = cfg.topic_prefix.trim_end_matches('/').to_string();
        let handle = std::thread::Builder::new()
            .name("mqtt".into())
            .spawn(move || sender(opts, queue, rx, cfg.capacity, cfg.drain_timeout))
            .map_err(|source| MqttError::Queue {
                path: PathBuf::from("<mqtt thread>"),
                source,
            })?;
        Ok(Self {
            tx,
            handle: Some(handle),
            prefix,
            windows: 0,
        })
    }

    /// Queue one window line (and, every [`HEALTH_EVERY`] windows, the health counters).
    pub fn send_window(&mut self, line: &str, health: &serde_json::Value) {
        let _ = self.tx.send(Msg::Publish {
            topic: format!("{}/diagnosis", self.prefix),
            payload: line.to_string(),
        });
        self.windows += 1;
        if self.windows % HEALTH_EVERY == 0 {
            let _ = self.tx.send(Msg::Publish {
                topic: format!("{}/health", self.prefix),
                payload: health.to_string(),
            });
        }
    }

    /// Drain the queue (up to the drain timeout) and return the counts.
    pub fn finish(mut self) -> MqttStats {
        let _ = self.tx.send(Msg::Finish);
        self.handle
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default()
    }
}

/// `{"seq":n,…}`: the payload with its sequence number first.
fn with_seq(seq: u64, payload: &str) -> String {
    match payload.strip_prefix('{') {
        Some(rest) if rest.trim_start().starts_with('}') => format!("{{\"seq\":{seq}}}"),
        Some(rest) => format!("{{\"seq\":{seq},{rest}"),
        None => payload.to_string(),
    }
}

fn sender(
    opts: MqttOptions,
    mut queue: DiskQueue,
    rx: Receiver<Msg>,
    capacity: usize,
    drain_timeout: Duration,
) -> MqttStats {
    let mut stats = MqttStats {
        produced: queue.entries.len() as u64,
        ..MqttStats::default()
    };
    let mut finishing: Option<Instant> = None;
    let mut conn: Option<(Client, Connection)> = None;
    let mut connected = false;
    let mut backoff = Duration::from_millis(100);
    // seqs published, waiting for their packet id (Outgoing::Publish), in order
    let mut awaiting_pkid: VecDeque<u64> = VecDeque::new();
    // (pkid, seq) on the wire
    let mut inflight: Vec<(u16, u64)> = Vec::new();
    // next queue position not yet published on this connection
    let mut next_unsent = 0usize;
    loop {
        // New lines from the gateway.
        loop {
            match rx.try_recv() {
                Ok(Msg::Publish { topic, payload }) => {
                    match queue.push(topic, payload) {
                        Ok(_) => stats.produced += 1,
                        Err(e) => eprintln!("pumptwin-edge: mqtt queue write failed: {e}"),
                    }
                    while queue.entries.len() > capacity {
                        let oldest = queue.entries[0].seq;
                        inflight.retain(|(_, s)| *s != oldest);
                        awaiting_pkid.retain(|s| *s != oldest);
                        let _ = queue.done(oldest);
                        next_unsent = next_unsent.saturating_sub(1);
                        stats.dropped += 1;
                    }
                }
                Ok(Msg::Finish) | Err(mpsc::TryRecvError::Disconnected) => {
                    finishing.get_or_insert_with(Instant::now);
                    break;
                }
                Err(mpsc::TryRecvError::Empty) => break,
            }
        }
        if let Some(t) = finishing {
            if queue.entries.is_empty() || t.elapsed() > drain_timeout {
                break;
            }
        }
        let (client, connection) = conn.get_or_insert_with(|| {
            let (c, n) = Client::new(opts.clone(), 64);
            (c, n)
        });
        // Publish in order while there is room on the wire.
        while connected && inflight.len() + awaiting_pkid.len() < INFLIGHT {
            let Some(e) = queue.entries.get_mut(next_unsent) else {
                break;
            };
            let payload = with_seq(e.seq, &e.payload);
            if client
                .try_publish(e.topic.clone(), QoS::AtLeastOnce, false, payload)
                .is_err()
            {
                break;
            }
            if e.sent {
                stats.resent += 1;
            }
            e.sent = true;
            awaiting_pkid.push_back(e.seq);
            next_unsent += 1;
        }
        match connection.recv_timeout(Duration::from_millis(50)) {
            Ok(Ok(Event::Incoming(Packet::ConnAck(_)))) => {
                connected = true;
                stats.connects += 1;
                backoff = Duration::from_millis(100);
            }
            Ok(Ok(Event::Outgoing(Outgoing::Publish(pkid)))) => {
                if let Some(seq) = awaiting_pkid.pop_front() {
                    inflight.push((pkid, seq));
                }
            }
            Ok(Ok(Event::Incoming(Packet::PubAck(ack)))) => {
                if let Some(pos) = inflight.iter().position(|(p, _)| *p == ack.pkid) {
                    let (_, seq) = inflight.remove(pos);
                    if let Some(qpos) = queue.entries.iter().position(|e| e.seq == seq) {
                        if qpos < next_unsent {
                            next_unsent -= 1;
                        }
                    }
                    if let Err(e) = queue.done(seq) {
                        eprintln!("pumptwin-edge: mqtt queue update failed: {e}");
                    }
                    stats.delivered += 1;
                }
            }
            Ok(Ok(_)) | Err(RecvTimeoutError::Timeout) => {}
            Ok(Err(e)) => {
                if connected {
                    eprintln!("pumptwin-edge: mqtt connection lost: {e}; queueing");
                }
                // Start over on a fresh connection: everything unacknowledged is sent again.
                conn = None;
                connected = false;
                inflight.clear();
                awaiting_pkid.clear();
                next_unsent = 0;
                std::thread::sleep(backoff);
                backoff = (backoff * 2).min(Duration::from_secs(5));
            }
            Err(RecvTimeoutError::Disconnected) => {
                conn = None;
                connected = false;
                inflight.clear();
                awaiting_pkid.clear();
                next_unsent = 0;
            }
        }
    }
    if let Some((client, _)) = conn.as_ref() {
        let _ = client.try_disconnect();
    }
    stats.pending = queue.entries.len() as u64;
    stats
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_and_seq() {
        assert_eq!(
            parse_url("mqtt://127.0.0.1:1884").unwrap(),
            ("127.0.0.1".into(), 1884, false)
        );
        assert_eq!(
            parse_url("mqtts://broker").unwrap(),
            ("broker".into(), 8883, true)
        );
        assert!(parse_url("http://x").is_err());
        assert!(parse_url("mqtt://:1").is_err());
        assert_eq!(with_seq(7, "{\"a\":1}"), "{\"seq\":7,\"a\":1}");
        assert_eq!(with_seq(7, "{}"), "{\"seq\":7}");
    }

    /// No broker: a full queue drops the oldest entries, counts them, and the counts
    /// add up; what is left stays on disk for the next run.
    #[test]
    fn full_queue_drops_oldest_and_counts() {
        let dir = std::env::temp_dir().join(format!("pumptwin-mqtt-full-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port(); // closed again: nobody listens
        let cfg = MqttConfig {
            url: format!("mqtt://127.0.0.1:{port}"),
            topic_prefix: "t".into(),
            client_id: "test".into(),
            credentials: None,
            ca_file: None,
            queue_dir: dir.clone(),
            capacity: 5,
            drain_timeout: Duration::from_millis(300),
        };
        let mut sink = MqttSink::start(cfg.clone()).unwrap();
        for k in 0..12 {
            sink.send_window(&format!("{{\"window\":{k}}}"), &serde_json::json!({}));
        }
        let s = sink.finish();
        assert_eq!(s.produced, 12);
        assert_eq!(s.delivered, 0);
        assert_eq!(s.dropped, 7);
        assert_eq!(s.pending, 5);
        assert_eq!(s.produced, s.delivered + s.dropped + s.pending);
        // The next run starts with the 5 newest.
        let q = DiskQueue::open(&dir).unwrap();
        let seqs: Vec<u64> = q.entries.iter().map(|e| e.seq).collect();
        assert_eq!(seqs, vec![7, 8, 9, 10, 11]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn queue_survives_a_restart_and_compacts() {
        let dir = std::env::temp_dir().join(format!("pumptwin-mqtt-q-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        {
            let mut q = DiskQueue::open(&dir).unwrap();
            for k in 0..5 {
                q.push("t".into(), format!("{{\"k\":{k}}}")).unwrap();
            }
            q.done(0).unwrap();
            q.done(2).unwrap(); // out of order: 1 still pending
        }
        let q = DiskQueue::open(&dir).unwrap();
        let seqs: Vec<u64> = q.entries.iter().map(|e| e.seq).collect();
        // The done prefix is 1 (0 acked); 2 is re-sent after a restart (at-least-once).
        assert_eq!(seqs, vec![1, 2, 3, 4]);
        assert_eq!(q.next_seq, 5);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
