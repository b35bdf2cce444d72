//! An agent that has lost its coordinator (`docs/network.md`): the exits
//! its running responses ran alone, kept as reports and sent to the
//! coordinator when the link is back, again and again until it says it
//! has them, so that they join the one trace.

use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use zenoh::qos::CongestionControl;
use zenoh::{Session, Wait};

use super::keys;
use crate::plugin::remote::{nonce, ExitReport, FromAgent};

/// How often a report waiting for its coordinator is sent again.
const RESEND: Duration = Duration::from_millis(250);

/// A report waiting to be taken.
struct Pending {
    name: String,
    system: String,
    run: String,
    exit: ExitReport,
}

/// The reports an agent keeps, and which coordinators it sees alive.
#[derive(Default)]
pub(super) struct Reports {
    pending: Mutex<Vec<Pending>>,
    alive: Mutex<HashSet<String>>,
    /// The agent is leaving: its coordinators still look alive, but have
    /// not lost it yet, so nothing is sent (its exits are said on stderr).
    leaving: AtomicBool,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Reports {
    /// Keeps the report of an exit run alone for `system`'s run `run`.
    pub(super) fn add(&self, system: &str, run: &str, exit: ExitReport) {
        lock(&self.pending).push(Pending {
            name: nonce(),
            system: system.to_string(),
            run: run.to_string(),
            exit,
        });
    }

    /// The coordinator took report `name`.
    pub(super) fn taken(&self, name: &str) {
        lock(&self.pending).retain(|p| p.name != name);
    }

    /// `system`'s coordinator came (`true`) or went.
    pub(super) fn system(&self, system: &str, alive: bool) {
        let mut set = lock(&self.alive);
        if alive {
            set.insert(system.to_string());
        } else {
            set.remove(system);
        }
    }

    /// The agent is leaving: no report is sent from now on.
    pub(super) fn leave(&self) {
        self.leaving.store(true, Ordering::Relaxed);
    }

    /// Sends every report whose coordinator is alive.
    fn send(&self, session: &Session, node: &str) {
        if self.leaving.load(Ordering::Relaxed) {
            return;
        }
        let alive = lock(&self.alive).clone();
        let due: Vec<(String, FromAgent)> = lock(&self.pending)
            .iter()
            .filter(|p| alive.contains(&p.system))
            .map(|p| {
                (
                    keys::agent_out(&p.system, node),
                    FromAgent::ExitsRan {
                        plugin: p.name.clone(),
                        run: p.run.clone(),
                        exits: vec![p.exit.clone()],
                    },
                )
            })
            .collect();
        for (key, message) in due {
            let bytes = serde_json::to_vec(&message).unwrap_or_default();
            let _ = session
                .put(key, bytes)
                .congestion_control(CongestionControl::Block)
                .wait();
        }
    }
}

/// Sends the reports of agent `node` while `running` holds.
pub(super) fn reporter(
    reports: Arc<Reports>,
    session: Session,
    node: String,
    running: Arc<AtomicBool>,
) {
    let _ = std::thread::Builder::new()
        .name("radar-agent-reports".into())
        .spawn(move || {
            while running.load(Ordering::Relaxed) {
                std::thread::sleep(RESEND);
                reports.send(&session, &node);
            }
        });
}
