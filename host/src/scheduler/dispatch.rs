//! How the scheduler answers each [`Command`]: deliberative code's
//! operations, the CLI's inputs, the native contexts' turns.

use std::sync::Arc;
use std::time::Duration;

use super::commands::{Command, ProgramFailure};
use super::run::Scheduler;
use super::state::{NativeTask, State, WaiterReply};
use crate::clock::duration_nanos;
use crate::payload::Payload;
use crate::trace::inputs::Input;
use crate::trace::Entry;

impl Scheduler {
    pub(super) fn handle(&mut self, cmd: Command) {
        let core = self.core.clone();
        if !cmd.is_outside_input() {
            core.with(State::count_move);
        }
        match cmd {
            Command::Connect {
                link,
                external,
                reply,
            } => {
                let result = core.with(|st| {
                    if external {
                        st.connect_from_outside(link)
                    } else {
                        st.connect(link)
                    }
                });
                let _ = reply.send(result);
            }
            Command::Disconnect {
                ids,
                reason,
                external,
            } => core.with(|st| {
                for id in ids {
                    if external {
                        st.record_input(Input::Disconnect { id: id.get() });
                    }
                    st.disconnect(id, reason);
                }
            }),
            Command::Node { node, lost } => core.with(|st| {
                if lost {
                    st.node_lost(&node);
                } else {
                    st.node_back(&node);
                }
            }),
            Command::ExitsReported { node, exits } => {
                core.with(|st| st.exits_reported(&node, exits))
            }
            Command::Answer {
                plugin,
                call,
                answer,
            } => core.with(|st| st.answer(&plugin, call, answer)),
            Command::Overview { reply } => {
                let _ = reply.send(core.with(|st| st.overview()));
            }
            Command::Recording { reply } => {
                let path = core.with(|st| {
                    let recorder = st.trace.inputs.as_mut()?;
                    recorder.flush();
                    let path = recorder.path().to_path_buf();
                    // Flushed here, on the writer's thread: all of it is
                    // whole lines now, whatever is written after.
                    let len = std::fs::metadata(&path).map_or(0, |m| m.len());
                    Some((path, len))
                });
                let _ = reply.send(path);
            }
            Command::Refused {
                command,
                from,
                reason,
            } => core.with(|st| st.refused(command, from, reason)),
            Command::Configure {
                changes,
                from,
                reply,
            } => {
                let _ = reply.send(core.with(|st| st.configure(changes, &from)));
            }
            Command::Inject {
                to,
                payload,
                at,
                external,
                reply,
            } => {
                let result = core.with(|st| {
                    let mut injection = st.prepare_inject(&to, payload)?;
                    injection.external = external;
                    st.inject_at(&core, injection, at);
                    Ok(())
                });
                let _ = reply.send(result);
            }
            Command::WaitFor {
                event,
                timeout,
                lockstep,
                reply,
            } => core.with(|st| {
                let from = match st.resolve_signal(&event) {
                    Ok(from) => from,
                    Err(e) => {
                        let _ = reply.send(Err(e));
                        return;
                    }
                };
                let deadline = timeout.map(|t| st.now().saturating_add(duration_nanos(t)));
                st.add_waiter(
                    &core,
                    WaiterReply::WaitFor(reply),
                    lockstep,
                    Some(from),
                    deadline,
                );
            }),
            Command::Wait {
                mailbox,
                deadline,
                signal,
                lockstep,
                reply,
            } => core.with(|st| st.wait(&core, mailbox, deadline, signal, lockstep, reply)),
            Command::Sleep {
                duration,
                lockstep,
                reply,
            } => core.with(|st| {
                if lockstep {
                    st.turns.block();
                }
                let deadline = st.now().saturating_add(duration_nanos(duration));
                let core = core.clone();
                st.spawn(Box::pin(async move {
                    let _ = core.base.sleep_until(deadline, None).await;
                    core.with(|st| st.resume(lockstep, Box::new(move || reply.send(()).is_ok())));
                }));
            }),
            Command::Reset {
                plugin,
                external,
                reply,
            } => {
                let result = core.with(|st| st.request_reset(&plugin, external));
                let _ = reply.send(result);
            }
            Command::PluginState { plugin, reply } => {
                let _ = reply.send(core.with(|st| Ok(st.state_of(st.plugin(&plugin)?))));
            }
            Command::Now { reply } => {
                let _ = reply.send(Duration::from_nanos(core.base.now()));
            }
            Command::ProgramDone { outcome, stops_run } => core.with(|st| {
                st.turns.block();
                let (outcome_name, error) = match &outcome {
                    Ok(()) => ("ok", None),
                    Err(ProgramFailure::Error(e)) => ("error", Some(e.clone())),
                    Err(ProgramFailure::Panicked(m)) => ("panicked", Some(m.clone())),
                    Err(ProgramFailure::Stopped(status)) => {
                        ("stopped", Some(format!("status {status}")))
                    }
                };
                st.record(Entry::ProgramEnd {
                    outcome: outcome_name.into(),
                    error,
                });
                st.program_outcome = Some(outcome);
                if stops_run {
                    st.begin_stop("the deliberative program ended");
                }
            }),
            Command::AnonymousDone {
                slot,
                closure,
                panicked,
            } => core.with(|st| st.anonymous_done(slot, closure, panicked)),
            Command::BoardWrite {
                entry,
                value,
                by,
                external,
                reply,
            } => {
                let _ = reply.send(core.with(|st| {
                    let checked = st.board.value(&entry, &value)?;
                    if external {
                        // Recorded before the write's own record: a replay
                        // counts the records made before each input.
                        st.record_input(Input::BoardWrite {
                            entry: entry.clone(),
                            value,
                            by: by.clone(),
                        });
                    }
                    st.board_write(by.as_deref().unwrap_or("(native)"), &entry, checked);
                    Ok(())
                }));
            }
            Command::BoardRead { entry, reply } => {
                let _ = reply.send(core.with(|st| {
                    st.board.type_of(&entry)?;
                    Ok(st.board.read(&entry).map(|v| Payload(Some(Arc::new(v)))))
                }));
            }
            Command::Swap {
                plugin,
                code,
                policy,
                origin,
                reply,
            } => {
                let _ = reply
                    .send(core.with(|st| st.request_swap(&plugin, code, policy, origin.as_ref())));
            }
            Command::Spawn { go, reply } => core.with(|st| {
                st.next_native_task = st.next_native_task.next();
                let task = st.next_native_task;
                st.native_tasks.insert(
                    task,
                    NativeTask::Running {
                        joiners: Vec::new(),
                    },
                );
                let _ = reply.send(task);
                // Its first turn comes when the contexts ready before it
                // have blocked.
                st.turns.wake(Box::new(move || go.send(()).is_ok()));
            }),
            Command::TaskDone { task, outcome } => core.with(|st| {
                st.turns.block();
                if let Err(failure) = &outcome {
                    st.record(Entry::Log {
                        plugin: "(deliberative)".into(),
                        level: "error".into(),
                        message: format!("task {task} failed: {failure}"),
                    });
                }
                let ended = NativeTask::Ended(outcome.clone());
                if let Some(NativeTask::Running { joiners }) = st.native_tasks.insert(task, ended) {
                    for (lockstep, reply) in joiners {
                        let outcome = outcome.clone();
                        st.resume(lockstep, Box::new(move || reply.send(outcome).is_ok()));
                    }
                }
            }),
            Command::Join {
                task,
                lockstep,
                reply,
            } => core.with(|st| match st.native_tasks.get_mut(&task) {
                Some(NativeTask::Ended(outcome)) => {
                    let _ = reply.send(outcome.clone());
                }
                Some(NativeTask::Running { joiners }) => {
                    joiners.push((lockstep, reply));
                    if lockstep {
                        st.turns.block();
                    }
                }
                None => {}
            }),
            Command::Stop => core.with(|st| st.begin_stop("asked to stop")),
        }
        self.absorb();
    }
}
