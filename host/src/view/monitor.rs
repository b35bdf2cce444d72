//! `radar run --monitor`: the view of `radar view`, live (`docs/view.md`).
//!
//! A small HTTP server on its own threads: `GET /` is the page, `GET
//! /events` streams the trace as server-sent events (every record so far,
//! then each as it happens), `GET /trace.jsonl` is the trace so far, `GET
//! /snapshot` the page with the records so far and no stream (for a
//! headless browser's screenshot, which waits for the network to go
//! quiet and so never ends on the live page). The
//! run only keeps each record, and hands what it kept to a channel when it
//! has nothing due ([`MonitorSink`], as the trace file's sink does): no
//! wake-up on the run's path, and serving, serializing and slow browsers
//! never hold the scheduler.

use std::collections::VecDeque;
use std::io::{BufWriter, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};

use super::html::{live_page, write_view_of_lines};
use crate::trace::{Record, TraceSink, CLOCK_EVERY};

/// Records kept for a browser that opens the page late: a longer run
/// shows its last this many records (the page says how many it has).
pub const HISTORY: usize = 2_000_000;

/// Records a server-sent event carries at most when a page catches up.
const BATCH: usize = 5_000;

/// Batches waiting for one page at most: a page that falls this far
/// behind is dropped (its browser reconnects, and resumes where it was).
const CLIENT_QUEUE: usize = 1_024;

/// How long the run keeps records before handing them over when it is
/// never idle.
const SEND_EVERY: Duration = Duration::from_millis(100);

/// After taking what the run handed over, the server rests this long
/// before it looks again: whatever the run does, the server's threads run
/// at most about ten times a second (each time they run they take a
/// little of the caches the run would find warm), and a page shows the run
/// at most about this much late.
const PACE: Duration = Duration::from_millis(100);

/// What a monitor could not do.
#[derive(Debug, thiserror::Error)]
pub enum MonitorError {
    /// The address does not parse or resolve.
    #[error("monitor: `{0}` is not an address (e.g. 127.0.0.1:7878)")]
    Address(String),
    /// Nothing can listen there.
    #[error("monitor: cannot listen on {addr}: {source}")]
    Listen {
        /// Where.
        addr: String,
        /// Why not.
        source: std::io::Error,
    },
}

enum Message {
    /// Records as JSON lines.
    Lines(Vec<String>),
    End,
}

#[derive(Default)]
struct Shared {
    /// Every record so far (the last [`HISTORY`]), as JSON lines.
    history: VecDeque<Arc<str>>,
    /// Records that left the history's front ([`HISTORY`]): the first
    /// record in it is record number `forgotten` of the run.
    forgotten: usize,
    /// The open `/events` streams.
    clients: Vec<Sender<Arc<String>>>,
    ended: bool,
}

impl Shared {
    /// Records the run has written so far.
    fn total(&self) -> usize {
        self.forgotten + self.history.len()
    }
}

struct Hub {
    shared: Mutex<Shared>,
    stop: AtomicBool,
}

impl Hub {
    fn lock(&self) -> MutexGuard<'_, Shared> {
        // A poisoned lock only means a serving thread panicked: the data
        // (lines and senders) is still whole.
        self.shared.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The live monitor: serving from [`Monitor::start`] until dropped.
pub struct Monitor {
    addr: SocketAddr,
    hub: Arc<Hub>,
    tx: Sender<Message>,
    threads: Vec<JoinHandle<()>>,
    writers: Arc<Mutex<Vec<JoinHandle<()>>>>,
}

/// The trace sink that feeds a [`Monitor`]: records go to the server in
/// batches, when the run has nothing due or a batch is full.
pub struct MonitorSink {
    tx: Sender<Message>,
    pending: Vec<Record>,
    sent: Instant,
}

impl MonitorSink {
    /// Hands what was kept to the server as JSON lines. Made here, on the
    /// run's thread while it has nothing due (as the trace file's lines
    /// are), so that no other thread touches the records: their memory and
    /// the names they share stay with the run's core.
    fn send(&mut self) {
        self.sent = Instant::now();
        if !self.pending.is_empty() {
            let lines = self.pending.iter().map(Record::to_json_line).collect();
            self.pending.clear();
            let _ = self.tx.send(Message::Lines(lines));
        }
    }
}

impl TraceSink for MonitorSink {
    fn record(&mut self, record: &Record) {
        self.pending.push(record.clone());
        // The clock is read every CLOCK_EVERY records only: a read costs as much as
        // keeping a record.
        let n = self.pending.len();
        if n >= BATCH || (n.is_multiple_of(CLOCK_EVERY) && self.sent.elapsed() >= SEND_EVERY) {
            self.send();
        }
    }

    fn idle(&mut self) {
        self.send();
    }

    fn finish(&mut self) -> std::io::Result<()> {
        self.send();
        let _ = self.tx.send(Message::End);
        Ok(())
    }
}

impl Monitor {
    /// Listens on `addr` (`127.0.0.1:7878`; port 0 picks a free one) and
    /// serves the page titled `title`.
    pub fn start(addr: &str, title: &str) -> Result<Self, MonitorError> {
        let resolved = addr
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.next())
            .ok_or_else(|| MonitorError::Address(addr.to_string()))?;
        let listener = TcpListener::bind(resolved).map_err(|source| MonitorError::Listen {
            addr: addr.to_string(),
            source,
        })?;
        let local = listener
            .local_addr()
            .map_err(|source| MonitorError::Listen {
                addr: addr.to_string(),
                source,
            })?;
        let hub = Arc::new(Hub {
            shared: Mutex::new(Shared::default()),
            stop: AtomicBool::new(false),
        });
        let (tx, rx) = crossbeam_channel::unbounded();
        let writers = Arc::new(Mutex::new(Vec::new()));
        let page = Arc::new(Page {
            live: live_page(title),
            title: title.to_string(),
        });
        let fan_out = {
            let hub = hub.clone();
            std::thread::Builder::new()
                .name("radar-monitor".into())
                .spawn(move || fan_out(&hub, &rx))
                .expect("a thread")
        };
        let accept = {
            let hub = hub.clone();
            let writers = writers.clone();
            std::thread::Builder::new()
                .name("radar-monitor-http".into())
                .spawn(move || {
                    // Blocked in accept (no polling: nothing runs while no
                    // one connects); the stop comes with a connection.
                    while !hub.stop.load(Ordering::Relaxed) {
                        let stream = match listener.accept() {
                            Ok((stream, _)) => stream,
                            Err(_) => {
                                // Out of descriptors, say: not a busy loop.
                                std::thread::sleep(Duration::from_millis(50));
                                continue;
                            }
                        };
                        if hub.stop.load(Ordering::Relaxed) {
                            break;
                        }
                        let (hub, page) = (hub.clone(), page.clone());
                        if let Ok(handle) = std::thread::Builder::new()
                            .name("radar-monitor-client".into())
                            .spawn(move || serve(stream, &hub, &page))
                        {
                            let mut writers = writers.lock().unwrap_or_else(|e| e.into_inner());
                            writers.retain(|w: &JoinHandle<()>| !w.is_finished());
                            writers.push(handle);
                        }
                    }
                })
                .expect("a thread")
        };
        Ok(Self {
            addr: local,
            hub,
            tx,
            threads: vec![fan_out, accept],
            writers,
        })
    }

    /// Where it listens.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// A sink for the run's trace (`SystemBuilder::trace_to`).
    pub fn sink(&self) -> MonitorSink {
        MonitorSink {
            tx: self.tx.clone(),
            pending: Vec::with_capacity(BATCH),
            sent: Instant::now(),
        }
    }
}

impl Drop for Monitor {
    /// Stops serving: the pages open get the rest of the trace and the
    /// end of the stream (waiting at most a second for them), then the
    /// server closes.
    fn drop(&mut self) {
        let _ = self.tx.send(Message::End);
        // The fan-out thread ends at the end, once every record before it
        // is with the streams.
        let mut threads = self.threads.drain(..);
        if let Some(fan_out) = threads.next() {
            let _ = fan_out.join();
        }
        let deadline = Instant::now() + Duration::from_secs(1);
        let writers: Vec<JoinHandle<()>> = {
            let mut w = self.writers.lock().unwrap_or_else(|e| e.into_inner());
            w.drain(..).collect()
        };
        for w in writers {
            while !w.is_finished() && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(5));
            }
        }
        // The accept loop sees the stop with a connection of its own. Where
        // none can be made it is left to end with the process, not waited
        // for.
        self.hub.stop.store(true, Ordering::Relaxed);
        let mut wake = self.addr;
        if wake.ip().is_unspecified() {
            wake.set_ip(match wake {
                SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        if TcpStream::connect_timeout(&wake, Duration::from_millis(500)).is_ok() {
            for t in threads {
                let _ = t.join();
            }
        }
    }
}

/// Keeps the run's lines, and hands each batch to every open stream.
///
/// After each round it rests [`PACE`], while the run's batches wait in the
/// channel: at most about ten rounds a second, whatever the run does.
fn fan_out(hub: &Hub, rx: &Receiver<Message>) {
    loop {
        let Ok(first) = rx.recv() else { return };
        let mut lines = Vec::new();
        let mut end = false;
        for message in std::iter::once(first).chain(rx.try_iter()) {
            match message {
                Message::Lines(batch) => lines.extend(batch),
                Message::End => end = true,
            }
        }
        let mut shared = hub.lock();
        if !lines.is_empty() {
            let lines: Vec<Arc<str>> = lines.into_iter().map(Arc::from).collect();
            let total = shared.total() + lines.len();
            let event = Arc::new(event(&lines, total));
            // A page that fell too far behind is let go (it reconnects).
            shared.clients.retain(|c| c.try_send(event.clone()).is_ok());
            shared.history.extend(lines);
            let over = shared.history.len().saturating_sub(HISTORY);
            shared.history.drain(..over);
            shared.forgotten += over;
        }
        if end {
            shared.ended = true;
            let done = Arc::new(END.to_string());
            for c in shared.clients.drain(..) {
                let _ = c.send(done.clone());
            }
            return;
        }
        drop(shared);
        std::thread::sleep(PACE);
    }
}

/// The server-sent event that ends a stream: the run is over.
const END: &str = "event: end\ndata: the run ended\n\n";

/// A server-sent event carrying `lines`, one `data:` line each (the page
/// splits them at newlines again), whose id is the number of records up
/// to its last: a browser that reconnects says it (`Last-Event-ID`) and
/// is sent only what follows.
fn event(lines: &[Arc<str>], total: usize) -> String {
    let mut text = String::with_capacity(lines.iter().map(|l| l.len() + 7).sum::<usize>() + 24);
    for line in lines {
        text.push_str("data: ");
        text.push_str(line);
        text.push('\n');
    }
    text.push_str(&format!("id: {total}\n\n"));
    text
}

/// What the monitor serves of its page: the live page, and the title a
/// snapshot takes.
struct Page {
    live: String,
    title: String,
}

/// Answers one HTTP request (one connection).
fn serve(mut stream: TcpStream, hub: &Hub, page: &Page) {
    let _ = stream.set_read_timeout(Some(Duration::from_secs(5)));
    let _ = stream.set_write_timeout(Some(Duration::from_secs(10)));
    let mut request = Vec::new();
    let mut buf = [0u8; 2048];
    while !request.windows(4).any(|w| w == b"\r\n\r\n") && request.len() < 16 * 1024 {
        match stream.read(&mut buf) {
            Ok(0) | Err(_) => return,
            Ok(n) => request.extend_from_slice(&buf[..n]),
        }
    }
    let line = String::from_utf8_lossy(&request);
    let mut words = line.split_whitespace();
    let (method, path) = (words.next().unwrap_or(""), words.next().unwrap_or(""));
    let path = path.split('?').next().unwrap_or("");
    if method != "GET" {
        let _ = respond(
            &mut stream,
            "405 Method Not Allowed",
            "text/plain",
            b"GET only\n",
        );
        return;
    }
    match path {
        "/" | "/index.html" => {
            let _ = respond(
                &mut stream,
                "200 OK",
                "text/html; charset=utf-8",
                page.live.as_bytes(),
            );
        }
        // The run so far as `radar view` writes it: a page that holds its
        // records and opens no stream, so a headless browser's screenshot
        // (which waits for the network to go quiet) finishes.
        "/snapshot" | "/snapshot.html" => {
            let history: Vec<Arc<str>> = hub.lock().history.iter().cloned().collect();
            let mut body = Vec::new();
            let _ = write_view_of_lines(history.iter().map(|l| &**l), &page.title, &mut body);
            let _ = respond(&mut stream, "200 OK", "text/html; charset=utf-8", &body);
        }
        "/trace.jsonl" => {
            let history: Vec<Arc<str>> = hub.lock().history.iter().cloned().collect();
            let body: String = history.iter().map(|l| format!("{l}\n")).collect();
            let _ = respond(
                &mut stream,
                "200 OK",
                "application/x-ndjson",
                body.as_bytes(),
            );
        }
        "/events" => {
            // A browser that reconnects says how many records it has.
            let seen = line
                .lines()
                .filter_map(|l| l.split_once(':'))
                .find(|(name, _)| name.trim().eq_ignore_ascii_case("last-event-id"))
                .and_then(|(_, value)| value.trim().parse().ok())
                .unwrap_or(0);
            stream_events(stream, hub, seen);
        }
        _ => {
            let _ = respond(&mut stream, "404 Not Found", "text/plain", b"not found\n");
        }
    }
}

fn respond(stream: &mut TcpStream, status: &str, kind: &str, body: &[u8]) -> std::io::Result<()> {
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(body)?;
    stream.flush()
}

/// `/events`: the records after the first `seen`, then each batch as it
/// comes, until the run ends or the page goes away.
fn stream_events(stream: TcpStream, hub: &Hub, seen: usize) {
    let (tx, rx) = crossbeam_channel::bounded::<Arc<String>>(CLIENT_QUEUE);
    let mut out = BufWriter::new(stream);
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: keep-alive\r\n\r\n";
    if out
        .write_all(head.as_bytes())
        .and_then(|()| out.flush())
        .is_err()
    {
        return;
    }
    // Taken, and the stream registered, under the lock the history grows
    // under: no record is missed or sent twice. What was taken is written
    // after the lock is let go.
    let (history, first, ended) = {
        let mut shared = hub.lock();
        let skip = seen
            .saturating_sub(shared.forgotten)
            .min(shared.history.len());
        let history: Vec<Arc<str>> = shared.history.iter().skip(skip).cloned().collect();
        let first = shared.forgotten + skip;
        let ended = shared.ended;
        if !ended {
            shared.clients.push(tx);
        }
        (history, first, ended)
    };
    let mut upto = first;
    for chunk in history.chunks(BATCH) {
        upto += chunk.len();
        if out.write_all(event(chunk, upto).as_bytes()).is_err() {
            return;
        }
    }
    if ended {
        let _ = out.write_all(END.as_bytes()).and_then(|()| out.flush());
        return;
    }
    if out.flush().is_err() {
        return;
    }
    for batch in rx {
        if out
            .write_all(batch.as_bytes())
            .and_then(|()| out.flush())
            .is_err()
        {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::Entry;

    /// Bounded: a stream that never ends fails the test, not hangs it.
    fn connect(addr: SocketAddr) -> TcpStream {
        let s = TcpStream::connect(addr).expect("connects");
        s.set_read_timeout(Some(Duration::from_secs(20)))
            .expect("a timeout");
        s
    }

    fn get(addr: SocketAddr, path: &str) -> String {
        let mut s = connect(addr);
        write!(s, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").expect("asks");
        let mut text = String::new();
        let _ = s.read_to_string(&mut text);
        text
    }

    #[test]
    fn serves_the_page_the_records_so_far_and_the_rest_as_they_come() {
        let monitor = Monitor::start("127.0.0.1:0", "test").expect("listens");
        let mut sink = monitor.sink();
        let record = |t| Record {
            t,
            entry: Entry::Activate { plugin: "E".into() },
        };
        sink.record(&record(1));
        sink.idle();
        let deadline = Instant::now() + Duration::from_secs(10);
        while !get(monitor.addr(), "/trace.jsonl").contains("\"t\":1,") {
            assert!(Instant::now() < deadline, "the record never arrived");
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(get(monitor.addr(), "/").contains("const RADAR_LIVE = true;"));
        assert!(get(monitor.addr(), "/nothing").starts_with("HTTP/1.1 404"));
        let addr = monitor.addr();
        let events = std::thread::spawn(move || get(addr, "/events"));
        std::thread::sleep(Duration::from_millis(100));
        sink.record(&record(2));
        sink.finish().expect("finishes");
        let events = events.join().expect("read");
        let first = events.find("\"t\":1,").expect("history");
        let second = events.find("\"t\":2,").expect("live record");
        assert!(first < second);
        assert!(
            events
                .trim_end()
                .ends_with("event: end\ndata: the run ended"),
            "{events}"
        );
        // A browser that reconnects after record 1 gets only what follows
        // (and, the run being over, the end at once).
        let mut s = connect(monitor.addr());
        write!(s, "GET /events HTTP/1.1\r\nLast-Event-ID: 1\r\n\r\n").expect("asks");
        let mut resumed = String::new();
        let _ = s.read_to_string(&mut resumed);
        assert!(
            !resumed.contains("\"t\":1,") && resumed.contains("\"t\":2,"),
            "{resumed}"
        );
        assert!(resumed.contains("id: 2\n"), "{resumed}");
        assert!(
            resumed.trim_end().ends_with("data: the run ended"),
            "{resumed}"
        );
        drop(monitor);
    }

    #[test]
    fn a_taken_port_is_a_one_line_error() {
        let first = Monitor::start("127.0.0.1:0", "a").expect("listens");
        let taken = first.addr().to_string();
        let err = Monitor::start(&taken, "b")
            .err()
            .expect("refused")
            .to_string();
        assert!(
            err.starts_with(&format!("monitor: cannot listen on {taken}")),
            "{err}"
        );
        assert!(Monitor::start("nowhere", "c").is_err());
    }
}
