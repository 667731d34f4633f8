//! Telemetry to a real broker with a restart in the middle: mosquitto on loopback,
//! the demo log replayed at recorded pace with `--mqtt`, the broker stopped after 3 s
//! and started again 2 s later. Every window's diagnosis arrives at a subscriber (by
//! `seq`, duplicates from QoS 1 redelivery counted) or is counted as dropped, and the
//! gateway's counts add up. Skips with a notice when `mosquitto` is not installed
//! (`.ci/run` installs it).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rumqttc::{Client, Event, MqttOptions, Packet, QoS};

fn mosquitto() -> Option<PathBuf> {
    ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
}

fn start_broker(bin: &Path, conf: &Path) -> Child {
    let child = Command::new(bin)
        .arg("-c")
        .arg(conf)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("mosquitto starts");
    std::thread::sleep(Duration::from_millis(400));
    child
}

#[test]
fn every_diagnosis_arrives_or_is_counted_across_a_broker_restart() {
    let Some(bin) = mosquitto() else {
        println!("SKIP: mosquitto not installed");
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = std::env::temp_dir().join(format!("pumptwin-mqtt-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("broker")).unwrap();
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let conf = dir.join("mosquitto.conf");
    std::fs::write(
        &conf,
        format!(
            "listener {port} 127.0.0.1\nallow_anonymous true\npersistence true\n\
             persistence_location {}/\nautosave_interval 1\n",
            dir.join("broker").display()
        ),
    )
    .unwrap();
    let mut broker = start_broker(&bin, &conf);

    // Subscriber: persistent session, QoS 1, resubscribes on every connect.
    let received: Arc<Mutex<Vec<(u64, u64)>>> = Arc::default();
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let sub = {
        let received = Arc::clone(&received);
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut opts = MqttOptions::new("pumptwin-test-sub", "127.0.0.1", port);
            opts.set_clean_session(false);
            opts.set_keep_alive(Duration::from_secs(5));
            let (client, mut conn) = Client::new(opts, 256);
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                match conn.recv_timeout(Duration::from_millis(100)) {
                    Ok(Ok(Event::Incoming(Packet::ConnAck(_)))) => {
                        let _ = client.try_subscribe("t/diagnosis", QoS::AtLeastOnce);
                    }
                    Ok(Ok(Event::Incoming(Packet::Publish(p)))) => {
                        let v: serde_json::Value = serde_json::from_slice(&p.payload).unwrap();
                        received
                            .lock()
                            .unwrap()
                            .push((v["seq"].as_u64().unwrap(), v["window"].as_u64().unwrap()));
                    }
                    Ok(Err(_)) => std::thread::sleep(Duration::from_millis(200)),
                    _ => {}
                }
            }
        })
    };
    std::thread::sleep(Duration::from_millis(500));

    let edge = Command::new(env!("CARGO_BIN_EXE_pumptwin-edge"))
        .current_dir(&root)
        .args([
            "--replay",
            "models/demo.log",
            "--sensors",
            "models/cwru-sensors.toml",
            "--model",
            "models/dsstgat-cwru-tb.ptm",
            "--speed",
            "realtime",
            "--mqtt",
            &format!("mqtt://127.0.0.1:{port}"),
            "--topic-prefix",
            "t",
            "--mqtt-drain-timeout",
            "30",
            "--mqtt-queue",
        ])
        .arg(dir.join("queue"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(3));
    let _ = Command::new("kill")
        .args(["-TERM", &broker.id().to_string()])
        .status();
    let _ = broker.wait();
    std::thread::sleep(Duration::from_secs(2));
    broker = start_broker(&bin, &conf);
    let out = edge.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{stderr}");
    let windows = String::from_utf8(out.stdout).unwrap().lines().count() as u64;
    let line = stderr
        .lines()
        .find(|l| l.contains("mqtt: produced"))
        .unwrap_or_else(|| panic!("no mqtt summary:\n{stderr}"));
    let nums: Vec<u64> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    let (produced, delivered, dropped, pending, resent, connects) =
        (nums[0], nums[1], nums[2], nums[3], nums[4], nums[5]);
    assert!(connects >= 2, "the broker restart was not seen: {line}");
    assert!(stderr.contains("connection lost"), "{stderr}");
    assert_eq!(produced, delivered + dropped + pending, "{line}");
    assert_eq!(pending, 0, "{line}");
    // Windows + one health message per 100 windows.
    assert_eq!(produced, windows + windows / 100, "{line}");
    // Wait for the subscriber to see everything.
    let t0 = Instant::now();
    let distinct = loop {
        let got: BTreeMap<u64, usize> =
            received
                .lock()
                .unwrap()
                .iter()
                .fold(BTreeMap::new(), |mut m, (_, w)| {
                    *m.entry(*w).or_default() += 1;
                    m
                });
        if got.len() as u64 + dropped >= windows || t0.elapsed() > Duration::from_secs(15) {
            break got;
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let _ = sub.join();
    let _ = Command::new("kill")
        .args(["-TERM", &broker.id().to_string()])
        .status();
    let _ = broker.wait();
    let duplicates: usize = distinct.values().map(|n| n - 1).sum();
    println!(
        "{windows} windows: produced {produced}, delivered {delivered}, dropped {dropped}, \
         resent {resent}, connects {connects}; subscriber saw {} distinct windows ({duplicates} duplicates)",
        distinct.len()
    );
    assert_eq!(distinct.len() as u64 + dropped, windows, "{line}");
    assert!(distinct.keys().copied().eq(0..distinct.len() as u64) || dropped > 0);
    let _ = std::fs::remove_dir_all(&dir);
}
