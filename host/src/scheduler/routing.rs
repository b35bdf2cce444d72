//! The connection table and signal routing: what happens, synchronously,
//! when a plugin emits a signal or deliberative code makes, ends or injects
//! into a connection. Nothing here calls into wasm: a delivery only changes
//! state and wakes the target's actor.

use super::*;

/// What a payload waiting in a [`Backlog`] takes.
pub(super) fn queued_bytes(payload: &Shared) -> usize {
    payload.as_deref().map_or(0, |v| {
        crate::payload::check_size(v, usize::MAX).unwrap_or(usize::MAX)
    })
}

impl State {
    pub(super) fn now(&self) -> u64 {
        self.base.now()
    }

    pub(super) fn tracing(&self) -> bool {
        !self.trace.sinks.is_empty() || self.trace.kept.is_some() || self.trace.digest.is_some()
    }

    pub(super) fn record(&mut self, entry: Entry) {
        // Whatever is recorded is progress (see `crate::watchdog`): a call
        // that keeps emitting or writing is not stalled.
        self.watch.step();
        // Lines a guest logged during the step that led here come first.
        self.record_logs();
        if !self.tracing() {
            return;
        }
        let t = self.now();
        self.write(Record { t, entry });
    }

    pub(super) fn write(&mut self, record: Record) {
        if let Some(digest) = &mut self.trace.digest {
            digest.observe(&record);
        }
        for sink in &mut self.trace.sinks {
            sink.record(&record);
        }
        self.trace.unflushed = true;
        if let Some(kept) = &mut self.trace.kept {
            kept.push(record);
        }
    }

    pub(super) fn record_logs(&mut self) {
        let lines = self.base.take_logs();
        if !self.tracing() {
            return;
        }
        for line in lines {
            self.write(Record {
                t: line.t,
                entry: Entry::Log {
                    plugin: line.plugin,
                    level: line.level.into(),
                    message: line.message,
                },
            });
        }
    }

    pub(super) fn spawn(&mut self, task: LocalTask) -> TaskId {
        self.next_task += 1;
        self.spawned.push((self.next_task, task));
        self.next_task
    }

    pub(super) fn plugin(&self, name: &str) -> Result<usize, RadarError> {
        self.by_name
            .get(name)
            .copied()
            .ok_or_else(|| RadarError::UnknownPlugin(name.to_string()))
    }

    pub(super) fn resolve_signal(&self, spec: &str) -> Result<(usize, Signal), RadarError> {
        let (name, port) = split_port(spec);
        let pid = self.plugin(name)?;
        let entry = &self.plugins[pid];
        let default = if entry.is_event() {
            "triggered"
        } else {
            "exited"
        };
        let signal = match port.unwrap_or(default) {
            "triggered" => Signal::Triggered,
            "started" => Signal::Started,
            "interrupted" => Signal::Interrupted,
            "exited" => Signal::Exited,
            "faulted" => Signal::Faulted,
            other => match entry
                .def
                .code
                .kind
                .signals()
                .iter()
                .find(|(n, _)| n.as_str() == other)
            {
                Some((name, _)) => Signal::Named(*name),
                None => return Err(self.unknown_port(pid, "signal", other)),
            },
        };
        if entry.signal_type(signal).is_none() {
            return Err(self.unknown_port(pid, "signal", signal.as_str()));
        }
        Ok((pid, signal))
    }

    pub(super) fn resolve_slot(&self, spec: &str) -> Result<(usize, Slot), RadarError> {
        let (name, port) = split_port(spec);
        let pid = self.plugin(name)?;
        let slot = match port.unwrap_or("start") {
            "start" => Slot::Start,
            "interrupt" | "until" => Slot::Interrupt,
            "exit" => Slot::Exit,
            other => return Err(self.unknown_port(pid, "slot", other)),
        };
        if self.plugins[pid].slot_type(slot).is_none() {
            return Err(self.unknown_port(pid, "slot", slot.as_str()));
        }
        Ok((pid, slot))
    }

    pub(super) fn unknown_port(&self, pid: usize, what: &'static str, name: &str) -> RadarError {
        let entry = &self.plugins[pid];
        let known = if what == "signal" {
            let built_in = if entry.is_event() {
                "triggered, faulted"
            } else {
                "started, interrupted, exited, faulted"
            };
            let declared = entry
                .def
                .code
                .kind
                .signals()
                .iter()
                .map(|(n, _)| n.as_str());
            std::iter::once(built_in)
                .chain(declared)
                .collect::<Vec<_>>()
                .join(", ")
        } else if entry.is_event() {
            "none: an event has no slots".to_string()
        } else {
            "start, interrupt, exit".to_string()
        };
        RadarError::UnknownPort {
            plugin: entry.def.name.clone(),
            what,
            name: name.to_string(),
            known,
        }
    }

    pub(super) fn signal_label(&self, (pid, signal): (usize, Signal)) -> String {
        format!("{}.{}", self.plugins[pid].def.name, signal.as_str())
    }

    pub(super) fn slot_label(&self, pid: usize, slot: Slot) -> String {
        format!("{}.{}", self.plugins[pid].def.name, slot.as_str())
    }

    /// Checks that `from`'s payload fits `(pid, slot)`; returns whether the
    /// slot takes the payload at all.
    pub(super) fn check_types(
        &self,
        from: (usize, Signal),
        pid: usize,
        slot: Slot,
    ) -> Result<bool, RadarError> {
        let emits = self.plugins[from.0].signal_type(from.1).flatten();
        let takes = self.plugins[pid].slot_type(slot).flatten();
        fits(&emits, &takes).map_err(|()| RadarError::TypeMismatch {
            from: self.signal_label(from),
            from_type: type_text(&emits),
            to: self.slot_label(pid, slot),
            to_type: type_text(&takes),
        })
    }

    pub(super) fn add_connection(
        &mut self,
        from: (usize, Signal),
        target: Target,
        conn: ConnectionParts,
    ) -> u64 {
        self.next_connection += 1;
        let id = self.next_connection;
        let from_label = self.signal_label(from);
        self.record(Entry::Connect {
            id,
            from: from_label,
            to: conn.to_label.clone(),
            mode: conn.mode.as_str().into(),
            busy: conn.busy.as_str().into(),
        });
        let routes = &mut self.routes[from.0];
        match routes.iter_mut().find(|(signal, _)| *signal == from.1) {
            Some((_, ids)) => ids.push(id),
            None => routes.push((from.1, vec![id])),
        }
        self.connections.insert(
            id,
            Connection {
                from,
                target,
                mode: conn.mode,
                busy: conn.busy,
                min_interval: conn.min_interval,
                last_delivery: None,
                until: None,
                serves: conn.serves,
                to_label: conn.to_label.into(),
                pass_payload: conn.pass_payload,
            },
        );
        if from.1 == Signal::Triggered {
            let entry = &mut self.plugins[from.0];
            entry.listeners += 1;
            if entry.listeners == 1 && entry.lifecycle == Lifecycle::Inactive {
                self.activate(from.0);
            }
        }
        id
    }

    pub(super) fn activate(&mut self, pid: usize) {
        let entry = &mut self.plugins[pid];
        entry.lifecycle = Lifecycle::Active;
        entry.stop.clear();
        entry.wake();
        let plugin = entry.name.clone();
        self.record(Entry::Activate { plugin });
    }

    pub(super) fn connect(&mut self, link: LinkSpec) -> Result<Vec<u64>, RadarError> {
        let from = self.resolve_signal(&link.from)?;
        let parts = |to_label: String, pass_payload: bool| ConnectionParts {
            mode: link.mode,
            busy: link.busy,
            min_interval: link.min_interval.map(duration_nanos),
            to_label,
            pass_payload,
            serves: None,
        };
        let anonymous = matches!(link.to, LinkTarget::Closure(_) | LinkTarget::Mailbox(_));
        if anonymous && link.until.is_some() {
            return Err(RadarError::InvalidConnection {
                from: link.from,
                to: "an anonymous slot".into(),
                cause: "`until` interrupts a response; an anonymous slot has nothing to interrupt"
                    .into(),
            });
        }
        match link.to {
            LinkTarget::Closure(closure) => {
                let slot = self.next_connection + 1;
                self.anonymous.insert(
                    slot,
                    Anonymous {
                        closure: Some(closure),
                        queue: Backlog::default(),
                        closed: false,
                    },
                );
                let id = self.add_connection(
                    from,
                    Target::Anonymous(slot),
                    parts("(anonymous)".into(), true),
                );
                Ok(vec![id])
            }
            LinkTarget::Mailbox(mailbox) => {
                self.mailboxes.entry(mailbox).or_default();
                let id = self.add_connection(
                    from,
                    Target::Mailbox(mailbox),
                    parts("(anonymous)".into(), true),
                );
                Ok(vec![id])
            }
            LinkTarget::Slot(to) => {
                let (pid, slot) = self.resolve_slot(&to)?;
                let pass = self.check_types(from, pid, slot)?;
                let until = match &link.until {
                    None => None,
                    Some(_) if slot != Slot::Start => {
                        return Err(RadarError::InvalidConnection {
                            from: link.from,
                            to,
                            cause: "`until` goes with a connection to a response's start slot"
                                .into(),
                        })
                    }
                    Some(spec) => {
                        let f = self.resolve_signal(spec)?;
                        let pass_until = self.check_types(f, pid, Slot::Interrupt)?;
                        Some((f, pass_until))
                    }
                };
                let label = self.slot_label(pid, slot);
                let id = self.add_connection(from, Target::Slot(pid, slot), parts(label, pass));
                let mut ids = vec![id];
                if let Some((f, pass_until)) = until {
                    let until_parts = ConnectionParts {
                        mode: Mode::Whenever,
                        busy: Busy::Drop,
                        min_interval: None,
                        to_label: self.slot_label(pid, Slot::Interrupt),
                        pass_payload: pass_until,
                        serves: Some(id),
                    };
                    let until_id =
                        self.add_connection(f, Target::Slot(pid, Slot::Interrupt), until_parts);
                    if let Some(c) = self.connections.get_mut(&id) {
                        c.until = Some(until_id);
                    }
                    ids.push(until_id);
                }
                Ok(ids)
            }
        }
    }

    pub(super) fn disconnect(&mut self, id: u64, reason: &'static str) {
        let Some(conn) = self.connections.remove(&id) else {
            return; // already gone (a once that fired, an until that ended)
        };
        if let Some((_, ids)) = self.routes[conn.from.0]
            .iter_mut()
            .find(|(signal, _)| *signal == conn.from.1)
        {
            ids.retain(|i| *i != id);
        }
        self.record(Entry::Disconnect {
            id,
            reason: reason.into(),
        });
        match conn.target {
            Target::Anonymous(slot) => {
                if let Some(a) = self.anonymous.get_mut(&slot) {
                    a.closed = true;
                    if a.closure.is_some() && a.queue.is_empty() {
                        self.anonymous.remove(&slot);
                    }
                }
            }
            Target::Waiter(w) => {
                if reason != "fired" {
                    self.finish_waiter(w, None);
                }
            }
            // Deliveries already in the mailbox stay there for the program.
            Target::Slot(..) | Target::Mailbox(_) => {}
        }
        if let (Mode::Whenever, Some(until)) = (conn.mode, conn.until) {
            // `whenever E start R until F`: F listens as long as E does. (A
            // `once`'s F lives with the activation it started instead.)
            self.disconnect(until, reason);
        }
        if conn.from.1 == Signal::Triggered {
            let pid = conn.from.0;
            let entry = &mut self.plugins[pid];
            entry.listeners -= 1;
            if entry.listeners == 0 && entry.lifecycle == Lifecycle::Active {
                entry.lifecycle = Lifecycle::Inactive;
                entry.stop.request(StopReason::Deactivate);
                let plugin = entry.name.clone();
                self.record(Entry::Deactivate { plugin });
            }
        }
    }

    /// Emits `signal` from `pid` and routes it to every connection, in the
    /// order the connections were made.
    pub(super) fn emit(&mut self, pid: usize, signal: Signal, payload: Shared) {
        self.watch.step();
        if self.tracing() {
            let plugin = self.plugins[pid].name.clone();
            let json = payload.as_deref().map(trace_json).unwrap_or(Json::Null);
            self.record(Entry::Signal {
                plugin,
                signal: signal.as_str().into(),
                payload: json,
            });
        }
        // Deliveries may remove connections, so the matching ids are taken
        // first, into a buffer kept between signals (no allocation here).
        let mut ids = std::mem::take(&mut self.route_buffer);
        if let Some((_, live)) = self.routes[pid].iter().find(|(s, _)| *s == signal) {
            ids.extend_from_slice(live);
        }
        for &id in &ids {
            self.deliver(id, &payload);
        }
        ids.clear();
        self.route_buffer = ids;
        // Counted once the emission is recorded and delivered: a burst's
        // record comes after the signal that crossed the limit.
        if self.base.kind() == ClockKind::Virtual {
            self.count_signal(pid);
        }
    }

    /// Counts a signal `pid` emits at the current virtual instant; past
    /// the instant's limit, a burst (see [`InstantSignals`]).
    pub(super) fn count_signal(&mut self, pid: usize) {
        let now = self.now();
        let instant = self.instant.at(now);
        instant.signals += 1;
        let over = instant.signals >= instant.limit;
        *self.plugins[pid].burst.at(now).0 += 1;
        if over {
            self.burst(false);
        }
    }

    /// Counts a task step at the current virtual instant, `pid`'s if the
    /// task is a plugin's actor; past the instant's limit, a burst.
    pub(super) fn count_task_step(&mut self, pid: Option<usize>) {
        let now = self.now();
        let instant = self.instant.at(now);
        instant.steps += 1;
        let over = instant.steps >= instant.step_limit;
        if let Some(pid) = pid {
            *self.plugins[pid].burst.at(now).1 += 1;
        }
        if over {
            self.burst(true);
        }
    }

    /// The instant's signals (or task steps) passed their limit: a plugin
    /// that made more than three quarters of them is to blame, and faults
    /// (at its next host call, or before its next call), and the run goes
    /// on; if none did (a loop through several plugins), the run is
    /// stopped as a livelock, with a `stopped` record that says why.
    fn burst(&mut self, steps: bool) {
        let now = self.now();
        let (total, what) = if steps {
            let total = self.instant.steps;
            self.instant.steps = 0;
            (total, "task steps")
        } else {
            let total = self.instant.signals;
            self.instant.signals = 0;
            (total, "signals")
        };
        let mut blamed: Option<(usize, u64)> = None;
        for (pid, entry) in self.plugins.iter_mut().enumerate() {
            let (signals, task_steps) = entry.burst.at(now);
            let count = if steps { task_steps } else { signals };
            let made = std::mem::take(count);
            if made * 4 > total * 3 && blamed.is_none_or(|(_, m)| made > m) {
                blamed = Some((pid, made));
            }
        }
        let at = now as f64 / 1e9;
        match blamed {
            Some((pid, made)) => {
                let cause = if steps {
                    format!(
                        "a burst: it took {made} of {total} task steps at {at:.3} s without \
                         virtual time advancing (a loop of yields that takes no time)"
                    )
                } else {
                    format!(
                        "a burst: it emitted {made} of {total} signals at {at:.3} s without \
                         virtual time advancing (a loop that takes no time, or too many \
                         signals in one call)"
                    )
                };
                self.plugins[pid].stop.request_fault(cause);
            }
            None if self.instant.livelock.is_none() => {
                self.instant.livelock = Some(now);
                self.stop = true;
                let message = format!(
                    "{total} {what} at {at:.3} s without virtual time advancing, no plugin \
                     making three quarters of them: something loops without taking time \
                     (connections that form a loop, such as `A.exited → B.start` and \
                     `B.exited → A.start` with starts that return at once); the run is stopped"
                );
                // Recorded as the run's last record when it ends (a call
                // still running may emit more before it does).
                self.watch.stop(crate::watchdog::Stopping {
                    reason: "livelock",
                    message,
                });
            }
            None => {}
        }
    }

    pub(super) fn deliver(&mut self, id: u64, payload: &Shared) {
        let now = self.now();
        let Some(conn) = self.connections.get_mut(&id) else {
            return; // removed by an earlier delivery of this same signal
        };
        if let (Some(min), Some(last)) = (conn.min_interval, conn.last_delivery) {
            if now < last.saturating_add(min) {
                let to = conn.to_label.clone();
                self.record(Entry::Dropped {
                    id,
                    to,
                    reason: "min-interval".into(),
                });
                return;
            }
        }
        conn.last_delivery = Some(now);
        let (target, busy, mode, to) = (conn.target, conn.busy, conn.mode, conn.to_label.clone());
        let (serves, until) = (conn.serves, conn.until);
        // A `once`'s until connection lives as long as the activation it
        // starts; a `whenever`'s lives as long as the whenever itself.
        let until = until.filter(|_| mode == Mode::Once);
        let payload = if conn.pass_payload {
            payload.clone()
        } else {
            None
        };
        let accepted = match target {
            Target::Slot(pid, slot) => {
                let delivery = Delivery {
                    via: id,
                    payload,
                    busy,
                    until,
                    serves,
                };
                self.deliver_to_slot(pid, slot, delivery)
            }
            Target::Anonymous(slot) => {
                let bytes = queued_bytes(&payload);
                let queued = match self.anonymous.get_mut(&slot) {
                    Some(a) => a.queue.push(Payload(payload), bytes),
                    None => Ok(()),
                };
                self.dispatch_anonymous(slot);
                queued
            }
            Target::Waiter(w) => {
                self.finish_waiter(w, Some(Payload(payload)));
                Ok(())
            }
            Target::Mailbox(mailbox) => self.mail(mailbox, id, Payload(payload)),
        };
        match accepted {
            Ok(()) => {
                if self.tracing() {
                    self.record(Entry::Deliver { id, to });
                }
            }
            Err(reason) => {
                self.record(Entry::Dropped {
                    id,
                    to,
                    reason: reason.into(),
                });
                if let Some(u) = until {
                    self.disconnect(u, "until");
                }
            }
        }
        if mode == Mode::Once {
            self.disconnect(id, "fired");
        }
    }

    /// Hands a payload to a response's slot under the busy policy; the
    /// error is the reason it was not taken.
    pub(super) fn deliver_to_slot(
        &mut self,
        pid: usize,
        slot: Slot,
        delivery: Delivery,
    ) -> Result<(), &'static str> {
        let entry = &mut self.plugins[pid];
        if entry.lifecycle == Lifecycle::Error {
            return Err("error");
        }
        let Delivery {
            via,
            payload,
            busy,
            until,
            serves,
        } = delivery;
        match slot {
            Slot::Start => {
                let request = StartRequest {
                    payload,
                    via,
                    until,
                };
                if entry.phase == Phase::Idle {
                    entry.next = Some(request);
                    entry.wake();
                    self.set_phase(pid, Phase::Running);
                    return Ok(());
                }
                match busy {
                    Busy::Drop => Err("busy"),
                    Busy::Queue(limit) => {
                        if entry.queue.len() >= limit {
                            return Err("queue-full");
                        }
                        entry.queue.push_back(request);
                        Ok(())
                    }
                    Busy::Restart => {
                        // The running activation stops as by an exit signal;
                        // this start runs next, ahead of the queue, replacing
                        // one accepted before it that has not begun.
                        let replaced = entry.next.replace(request);
                        let running = entry.activation.is_some() && entry.phase == Phase::Running;
                        if running && entry.stop_request.is_none() {
                            entry.stop_request = Some((StopReason::Exit, None));
                            entry.stop.request(StopReason::Exit);
                        }
                        if let Some(old) = replaced {
                            self.withdraw_start(pid, old, "restarted");
                        }
                        Ok(())
                    }
                }
            }
            Slot::Interrupt | Slot::Exit => {
                let reason = if slot == Slot::Interrupt {
                    StopReason::Interrupt
                } else {
                    StopReason::Exit
                };
                if let Some(serves) = serves {
                    // `until`: only the activations its own connection started.
                    match entry.activation_via() {
                        None => return Err("idle"),
                        Some(via) if via != serves => return Err("other-activation"),
                        Some(_) => {}
                    }
                }
                match (entry.phase, &entry.stop_request) {
                    (Phase::Running, None) => {
                        entry.stop_request = Some((reason, payload));
                        entry.stop.request(reason);
                        Ok(())
                    }
                    (Phase::Running, Some(_)) => Err("stopping"),
                    (Phase::Idle, _) => Err("idle"),
                    (Phase::Interrupting, _) => Err("interrupting"),
                    (Phase::Exiting, _) => Err("exiting"),
                }
            }
        }
    }

    /// An accepted start leaves without beginning: recorded as dropped with
    /// `reason` (the conservation law, DESIGN §1.1), and a `once ... until`
    /// connection that would have lived with its activation ends.
    pub(super) fn withdraw_start(
        &mut self,
        pid: usize,
        request: StartRequest,
        reason: &'static str,
    ) {
        let to = self.plugins[pid].start_label.clone();
        self.record(Entry::Dropped {
            id: request.via,
            to,
            reason: reason.into(),
        });
        if let Some(u) = request.until {
            self.disconnect(u, "until");
        }
    }

    pub(super) fn set_phase(&mut self, pid: usize, phase: Phase) {
        let entry = &mut self.plugins[pid];
        if entry.phase == phase {
            return;
        }
        entry.phase = phase;
        if self.tracing() {
            let plugin = self.plugins[pid].name.clone();
            self.record(Entry::State {
                plugin,
                state: phase.as_str().into(),
            });
        }
    }

    /// Resumes a native context that was blocked: in turn under the
    /// virtual clock if it is one of the run's (`lockstep`), else at once.
    pub(super) fn resume(&mut self, lockstep: bool, resume: turns::Resume) {
        if lockstep {
            self.turns.wake(resume);
        } else {
            resume();
        }
    }

    /// Hands the next delivery of anonymous slot `slot` to Radar's
    /// anonymous-slot thread, which runs one slot at a time (a slot that
    /// blocks in `sleep` holds the thread, not the scheduler).
    pub(super) fn dispatch_anonymous(&mut self, slot: u64) {
        let Some(a) = self.anonymous.get_mut(&slot) else {
            return;
        };
        if a.closure.is_none() || a.queue.is_empty() {
            return; // running now (the next delivery waits for it), or nothing to do
        }
        if self.runner_busy {
            if !self.runner_waiting.contains(&slot) {
                self.runner_waiting.push_back(slot);
            }
            return;
        }
        let (Some(payload), Some(closure)) = (a.queue.pop_front(), a.closure.take()) else {
            return;
        };
        self.runner_busy = true;
        let job = AnonymousJob {
            slot,
            closure,
            payload,
        };
        let jobs = self.anonymous_jobs.clone();
        // A runner that is gone (the run is ending) takes no turn.
        self.turns.wake(Box::new(move || jobs.send(job).is_ok()));
    }

    pub(super) fn anonymous_done(&mut self, slot: u64, closure: AnonymousSlot, panicked: bool) {
        self.turns.block();
        self.runner_busy = false;
        if panicked {
            self.record(Entry::Log {
                plugin: "(deliberative)".into(),
                level: "error".into(),
                message: format!("anonymous slot of connection {slot} panicked"),
            });
        }
        if let Some(a) = self.anonymous.get_mut(&slot) {
            a.closure = Some(closure);
            if a.closed && a.queue.is_empty() {
                self.anonymous.remove(&slot);
            } else if !a.queue.is_empty() && !self.runner_waiting.contains(&slot) {
                self.runner_waiting.push_back(slot);
            }
        }
        while !self.runner_busy {
            let Some(next) = self.runner_waiting.pop_front() else {
                break;
            };
            self.dispatch_anonymous(next);
        }
    }

    /// Registers a wait that ends with `from`'s next emission (if any), at
    /// `deadline` (if any), or as its reply's kind allows (a component's
    /// mailbox): the one path of native `waitfor` and a component's `wait`.
    pub(super) fn add_waiter(
        &mut self,
        core: &Rc<Core>,
        reply: WaiterReply,
        lockstep: bool,
        from: Option<(usize, Signal)>,
        deadline: Option<u64>,
    ) -> u64 {
        if lockstep {
            self.turns.block();
        }
        self.next_waiter += 1;
        let w = self.next_waiter;
        // Registered before the connection exists so that an immediate
        // delivery finds it.
        self.waiters.insert(
            w,
            Waiter {
                reply,
                lockstep,
                timeout_task: None,
                connection: 0,
            },
        );
        let connection = from.map(|from| {
            let parts = ConnectionParts {
                mode: Mode::Once,
                busy: Busy::Drop,
                min_interval: None,
                to_label: "(waitfor)".into(),
                pass_payload: true,
                serves: None,
            };
            self.add_connection(from, Target::Waiter(w), parts)
        });
        let timeout_task = deadline.map(|deadline| {
            let core = core.clone();
            self.spawn(Box::pin(async move {
                let _ = core.base.sleep_until(deadline, None).await;
                core.with(|st| st.finish_waiter(w, None));
            }))
        });
        if let Some(waiter) = self.waiters.get_mut(&w) {
            waiter.timeout_task = timeout_task;
            waiter.connection = connection.unwrap_or(0);
        }
        w
    }

    pub(super) fn finish_waiter(&mut self, w: u64, payload: Option<Payload>) {
        let Some(waiter) = self.waiters.remove(&w) else {
            return;
        };
        if let Some(task) = waiter.timeout_task {
            self.cancelled.push(task);
        }
        if payload.is_none() {
            // Timed out (or ended by the run stopping): end the wait's connection.
            self.disconnect(waiter.connection, "timeout");
        }
        match waiter.reply {
            WaiterReply::WaitFor(reply) => self.resume(
                waiter.lockstep,
                Box::new(move || reply.send(Ok(payload)).is_ok()),
            ),
            WaiterReply::Wait { mailbox, reply } => {
                if let Some(m) = self.mailboxes.get_mut(&mailbox) {
                    m.waiter = None;
                }
                let woke = payload.map_or(Woke::Deadline, Woke::Signal);
                self.resume(
                    waiter.lockstep,
                    Box::new(move || reply.send(Ok(woke)).is_ok()),
                )
            }
        }
    }

    pub(super) fn fault(&mut self, pid: usize, fault: Fault) {
        if fault.run_stopped {
            // Not the plugin's doing: the run ends, and says why.
            self.stop = true;
            return;
        }
        let entry = &mut self.plugins[pid];
        entry.lifecycle = Lifecycle::Error;
        entry.stop.clear();
        entry.stop.clear_fault();
        entry.stop_request = None;
        let withdrawn: Vec<StartRequest> = entry
            .next
            .take()
            .into_iter()
            .chain(entry.queue.drain(..))
            .collect();
        let activation = entry.activation.take();
        let plugin = entry.name.clone();
        if !entry.is_event() {
            entry.phase = Phase::Idle;
        }
        if crate::limits::is_machine_limit(&fault.cause) {
            let (count, _) = self
                .machine_limit
                .get_or_insert_with(|| (0, format!("{plugin}: {}", fault.cause)));
            *count += 1;
        }
        self.record(Entry::Fault {
            plugin: plugin.clone(),
            error: fault.cause.clone(),
            backtrace: fault.backtrace,
        });
        self.record(Entry::State {
            plugin,
            state: "error".into(),
        });
        if let Some(u) = activation.and_then(|a| a.until) {
            self.disconnect(u, "until");
        }
        for request in withdrawn {
            self.withdraw_start(pid, request, "fault");
        }
        self.emit(
            pid,
            Signal::Faulted,
            Some(Arc::new(Val::String(fault.cause))),
        );
    }

    /// Resolves and parses an injection: the slot and the payload as the
    /// slot's type.
    pub(super) fn prepare_inject(&self, to: &str, payload: Json) -> Result<Injection, RadarError> {
        let (pid, slot) = self.resolve_slot(to)?;
        let label = self.slot_label(pid, slot);
        let value = match self.plugins[pid].slot_type(slot).flatten() {
            Some(ty) => {
                Some(
                    json_to_val(&payload, &ty).map_err(|cause| RadarError::BadPayload {
                        to: label.clone(),
                        cause,
                    })?,
                )
            }
            None => None,
        };
        Ok(Injection {
            pid,
            slot,
            label: label.into(),
            json: payload,
            value,
            external: false,
        })
    }

    /// Sends a prepared payload into its slot at `at` (now if `None` or
    /// past).
    pub(super) fn inject_at(
        &mut self,
        core: &Rc<Core>,
        injection: Injection,
        at: Option<Duration>,
    ) {
        match at.map(duration_nanos) {
            Some(at) if at > self.now() => {
                let waiting = core.clone();
                let external = injection.external;
                let task = async move {
                    let _ = waiting.base.sleep_until(at, None).await;
                    waiting.with(|st| st.inject(injection));
                };
                // An input's own task is not one of the run's moves.
                self.spawn(if external {
                    super::inputs::input_task(core.clone(), task)
                } else {
                    Box::pin(task)
                });
            }
            _ => self.inject(injection),
        }
    }

    /// Sends a prepared payload straight into its slot.
    pub(super) fn inject(&mut self, injection: Injection) {
        let Injection {
            pid,
            slot,
            label,
            json,
            value,
            external,
        } = injection;
        if external {
            self.record_input(crate::trace::inputs::Input::Inject {
                to: label.to_string(),
                payload: json.clone(),
            });
        }
        self.record(Entry::Inject {
            to: label.clone(),
            payload: json,
        });
        let delivery = Delivery {
            via: 0,
            payload: value.map(Arc::new),
            busy: Busy::Drop,
            until: None,
            serves: None,
        };
        // Like a connection's delivery, an injection is recorded as
        // delivered or dropped, with id 0.
        match self.deliver_to_slot(pid, slot, delivery) {
            Ok(()) => self.record(Entry::Deliver { id: 0, to: label }),
            Err(reason) => self.record(Entry::Dropped {
                id: 0,
                to: label,
                reason: reason.into(),
            }),
        }
    }

    pub(super) fn setup(&self, pid: usize) -> (Rc<PluginCode>, InstanceSetup) {
        let entry = &self.plugins[pid];
        (
            entry.def.code.clone(),
            InstanceSetup {
                name: entry.name.clone(),
                base: self.base.clone(),
                stop: entry.stop.clone(),
                config: entry.def.config.clone(),
                limits: entry.def.limits.clone(),
                wasi: entry.def.wasi.clone(),
                seed: self.seed,
                fuel_used: entry.fuel_used.clone(),
                budget: self.budget.clone(),
                watch: self.watch.clone(),
            },
        )
    }
}
