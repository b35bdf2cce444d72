//! Publishing a run as it goes: every trace record on
//! `radar/<system>/trace`, every emission on its signal's key, every
//! blackboard write on its entry's key.
//!
//! The scheduler must never wait for the network: records are handed to a
//! publishing thread through a bounded queue, and when the network falls
//! that far behind, records are left out of what is published (never out
//! of the run or its trace file) and counted.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use crossbeam_channel::{bounded, Receiver, Sender, TrySendError};
use zenoh::{Session, Wait};

use super::keys;
use crate::trace::{Entry, Record, TraceSink};

/// Records waiting to be published, at most.
const QUEUE: usize = 65_536;

/// A trace sink that publishes (see the module docs).
pub(super) struct Publisher {
    tx: Option<Sender<Record>>,
    thread: Option<JoinHandle<()>>,
    left_out: Arc<AtomicU64>,
}

impl Publisher {
    pub(super) fn new(session: Session, system: String, left_out: Arc<AtomicU64>) -> Self {
        let (tx, rx) = bounded(QUEUE);
        let thread = std::thread::Builder::new()
            .name("radar-publish".into())
            .spawn(move || publish(session, system, rx))
            .ok();
        Self {
            tx: Some(tx),
            thread,
            left_out,
        }
    }
}

fn publish(session: Session, system: String, rx: Receiver<Record>) {
    let trace = session.declare_publisher(keys::trace(&system)).wait().ok();
    for record in rx {
        if let Some(trace) = &trace {
            let _ = trace.put(record.to_json_line()).wait();
        }
        let (key, value) = match &record.entry {
            Entry::Signal {
                plugin,
                signal,
                payload,
            } => (keys::signal(&system, plugin, signal), payload),
            Entry::BoardWrite { entry, value, .. } if keys::is_chunk(entry) => {
                (keys::board(&system, entry), value)
            }
            _ => continue,
        };
        let _ = session.put(key, value.to_string()).wait();
    }
}

impl TraceSink for Publisher {
    fn record(&mut self, record: &Record) {
        if let Some(tx) = &self.tx {
            if let Err(TrySendError::Full(_)) = tx.try_send(record.clone()) {
                self.left_out.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    fn finish(&mut self) -> std::io::Result<()> {
        // What is queued is published before the run's end is reported.
        self.tx = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        Ok(())
    }
}
