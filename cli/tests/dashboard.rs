//! `learner train --dashboard`: a short training run serves the page, the
//! JSON snapshot, the server-sent events and the replay, and the numbers
//! served are those of `metrics.csv`.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;

use buridan_learner::train::MetricsRow;

/// Kills the child when the test ends, whatever happens.
struct Guard(Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The body of `GET path` (panics unless the status is 200).
fn get(addr: SocketAddr, path: &str) -> Vec<u8> {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: test\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    assert!(head.starts_with("HTTP/1.1 200"), "{path}: {head}");
    raw[split + 4..].to_vec()
}

/// `x` (a metrics.csv value) and the JSON value served for it agree.
fn same(x: f64, served: &serde_json::Value) -> bool {
    match served.as_f64() {
        Some(y) => (x - y).abs() <= 1e-9 * x.abs().max(1.0),
        None => x.is_nan() && served.is_null(),
    }
}

/// Starts `command` with its stderr piped into a channel, line by line;
/// the child is killed when the guard drops.
fn spawn_logged(command: &mut Command) -> (Guard, mpsc::Receiver<String>) {
    let child = command
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut child = Guard(child);
    let stderr = child.0.stderr.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

/// The dashboard's event stream at `addr`, read past its greeting, and
/// what it sent so far.
fn open_events(addr: SocketAddr) -> (TcpStream, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(s, "GET /api/events HTTP/1.1\r\nHost: test\r\n\r\n").unwrap();
    let mut seen = String::new();
    let mut buf = [0u8; 1024];
    while !seen.contains("event: hello") {
        let n = s.read(&mut buf).unwrap();
        assert!(n > 0, "the event stream closed: {seen}");
        seen.push_str(&String::from_utf8_lossy(&buf[..n]));
    }
    (s, seen)
}

#[test]
fn a_training_run_serves_its_dashboard() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let config = common::tiny_config(dir.path());
    let (_child, rx) = spawn_logged(
        Command::new(env!("CARGO_BIN_EXE_learner"))
            .args(["train", "--config"])
            .arg(&config)
            .args(["--steps", "3000", "--seed", "5", "--quiet"])
            .args(["--dashboard", "127.0.0.1:0", "--dashboard-eval", "3"])
            .args(["--dashboard-linger", "600", "--out"])
            .arg(&out),
    );
    // "dashboard at http://ADDR" at the start; "... for 600 s more" once
    // the run, its final evaluation and its summary are done.
    let mut addr: Option<SocketAddr> = None;
    let mut log = Vec::new();
    loop {
        let line = rx
            .recv()
            .unwrap_or_else(|_| panic!("learner ended early:\n{}", log.join("\n")));
        log.push(line.clone());
        if let Some(rest) = line.strip_prefix("dashboard at http://") {
            let a = rest.split_whitespace().next().unwrap();
            addr.get_or_insert_with(|| a.parse().unwrap());
            if rest.ends_with("s more") {
                break;
            }
        }
    }
    let addr = addr.unwrap();

    let page = String::from_utf8(get(addr, "/")).unwrap();
    assert!(page.contains("<script src=\"/app.js\"></script>"), "{page}");
    let script = String::from_utf8(get(addr, "/app.js")).unwrap();
    assert!(script.contains("new EventSource(\"/api/events\")"));

    let state: serde_json::Value = serde_json::from_slice(&get(addr, "/api/state")).unwrap();
    let rows: Vec<MetricsRow> = csv::Reader::from_path(out.join("metrics.csv"))
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap();
    let served = state["rows"].as_array().unwrap();
    assert_eq!(served.len(), rows.len());
    assert!(rows.len() >= 3, "{} updates", rows.len());
    for (row, s) in rows.iter().zip(served) {
        let csv = serde_json::to_value(row).unwrap();
        for (k, v) in csv.as_object().unwrap() {
            let x = v.as_f64().unwrap_or(f64::NAN);
            assert!(
                same(x, &s[k]),
                "update {}: {k} is {x} in metrics.csv, {} served",
                row.update,
                s[k]
            );
        }
    }
    assert_eq!(state["run"]["steps"], 3000);
    assert_eq!(state["run"]["map"], "rm-1.1");
    let accepted = state["status"]["fragments"]["accepted"].as_u64().unwrap();
    assert!(accepted > 0, "{}", state["status"]);
    assert_eq!(state["eval"]["episodes"], 3);
    assert_eq!(state["eval"]["checkpoint"], "final");
    assert!(state["replay"]["caption"]
        .as_str()
        .unwrap()
        .starts_with("final: episode"));
    assert_eq!(&get(addr, "/api/replay.gif")[..6], b"GIF89a");

    // The live stream answers, starting with its greeting.
    let (_stream, seen) = open_events(addr);
    assert!(seen.contains("text/event-stream"), "{seen}");
}

#[test]
fn an_address_that_cannot_be_bound_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let config = common::tiny_config(dir.path());
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let output = Command::new(env!("CARGO_BIN_EXE_learner"))
        .args(["train", "--config"])
        .arg(&config)
        .args(["--steps", "1000", "--quiet", "--dashboard", &addr, "--out"])
        .arg(dir.path().join("run"))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(
        err.contains(&format!("cannot serve the dashboard on {addr}")),
        "{err}"
    );
}

/// Starts `learner ARGS --dashboard 127.0.0.1:0` on the tiny config, opens
/// the event stream as a browser tab would, waits until `ready` says the
/// run is under way, sends SIGTERM and asserts that the process exits
/// within 10 s, with the checkpoint of an interrupted run written.
#[cfg(unix)]
fn sigterm_ends_the_run_despite_an_open_page(
    command: &str,
    extra: &[&str],
    ready: fn(&std::path::Path) -> bool,
) {
    use std::time::{Duration, Instant};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let config = common::tiny_config(dir.path());
    let (mut child, rx) = spawn_logged(
        Command::new(env!("CARGO_BIN_EXE_learner"))
            .args([command, "--config"])
            .arg(&config)
            .args(["--steps", "100000000", "--seed", "5", "--quiet"])
            .args(["--set", "checkpoint_every=100000"])
            .args(["--dashboard", "127.0.0.1:0", "--dashboard-eval", "3"])
            .args(extra)
            .arg("--out")
            .arg(&out),
    );
    let mut log = Vec::new();
    let addr: SocketAddr = loop {
        let line = rx
            .recv_timeout(Duration::from_secs(120))
            .unwrap_or_else(|_| panic!("no dashboard address:\n{}", log.join("\n")));
        log.push(line.clone());
        if let Some(rest) = line.strip_prefix("dashboard at http://") {
            break rest.split_whitespace().next().unwrap().parse().unwrap();
        }
    };
    // The open page: its event stream stays connected through the stop.
    let (_page, _) = open_events(addr);
    let start = Instant::now();
    while !ready(&out) {
        assert!(start.elapsed() < Duration::from_secs(120), "never ready");
        assert!(child.0.try_wait().unwrap().is_none(), "ended early");
        std::thread::sleep(Duration::from_millis(50));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.0.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let signalled = Instant::now();
    let status = loop {
        if let Some(status) = child.0.try_wait().unwrap() {
            break status;
        }
        assert!(
            signalled.elapsed() < Duration::from_secs(10),
            "learner {command} still running 10 s after SIGTERM with a page open"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    while let Ok(line) = rx.recv_timeout(Duration::from_secs(1)) {
        log.push(line);
    }
    let log = log.join("\n");
    assert!(status.code().is_some(), "killed by the signal: {log}");
    let line = log
        .lines()
        .find(|l| l.contains("interrupted after update"))
        .unwrap_or_else(|| panic!("no interruption message in: {log}"));
    let checkpoint = line.split("--resume ").nth(1).unwrap().trim();
    assert!(
        buridan_policy::checkpoint::is_checkpoint(std::path::Path::new(checkpoint)),
        "{checkpoint} is not a checkpoint"
    );
}

#[cfg(unix)]
#[test]
fn sigterm_ends_training_with_a_dashboard_page_open() {
    // Under way: an update logged.
    sigterm_ends_the_run_despite_an_open_page("train", &[], |out| {
        std::fs::read_to_string(out.join("metrics.csv")).is_ok_and(|s| s.lines().count() > 1)
    });
}

#[cfg(unix)]
#[test]
fn sigterm_ends_serving_with_a_dashboard_page_open() {
    // The learner serves and waits for actors: it has written its config.
    let listen = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listen.local_addr().unwrap().to_string();
    drop(listen);
    let addr: &'static str = Box::leak(addr.into_boxed_str());
    sigterm_ends_the_run_despite_an_open_page("serve", &["--listen", addr], |out| {
        out.join("config.toml").is_file()
    });
}
