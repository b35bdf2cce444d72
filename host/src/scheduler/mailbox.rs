//! A deliberative component's anonymous slots. A component cannot be
//! called while it waits inside a host call, so its slots' deliveries go to
//! its mailbox, and the program's one blocking call, `wait`, ends with
//! whichever comes first: its deadline, the signal it waits for, or a
//! delivery (the Rust SDK then runs the slot's handler and waits again).
//! Under the virtual clock all of it happens in turns, deterministically;
//! a delivery is recorded as `deliver` when it reaches the mailbox.

use std::rc::Rc;
use std::time::Duration;

use crossbeam_channel::Sender;

use super::commands::Woke;
use super::ids::{ConnId, MailboxId};
use super::state::{Core, State, WaiterReply};
use crate::clock::duration_nanos;
use crate::error::RadarError;
use crate::payload::Payload;

impl State {
    /// `Command::Wait`.
    pub(super) fn wait(
        &mut self,
        core: &Rc<Core>,
        mailbox: MailboxId,
        deadline: Option<Duration>,
        signal: Option<String>,
        lockstep: bool,
        reply: Sender<Result<Woke, RadarError>>,
    ) {
        let mail = self.mailboxes.entry(mailbox).or_default();
        if let Some((connection, payload)) = mail.queue.pop_front() {
            let _ = reply.send(Ok(Woke::Delivery(connection, payload)));
            return;
        }
        let from = match signal
            .as_deref()
            .map(|s| self.resolve_signal(s))
            .transpose()
        {
            Ok(from) => from,
            Err(e) => {
                let _ = reply.send(Err(e));
                return;
            }
        };
        let deadline = deadline.map(duration_nanos);
        if from.is_none() && deadline.is_some_and(|d| d <= self.now()) {
            let _ = reply.send(Ok(Woke::Deadline));
            return;
        }
        let w = self.add_waiter(
            core,
            WaiterReply::Wait { mailbox, reply },
            lockstep,
            from,
            deadline,
        );
        if let Some(m) = self.mailboxes.get_mut(&mailbox) {
            m.waiter = Some(w);
        }
    }

    /// A delivery to a program's anonymous slot. It waits in the mailbox
    /// (or is dropped, `queue-full`, if the mailbox is full); if the
    /// program is waiting, it is woken for it once the emission that
    /// brought it has reached every connection (so a `waitfor` of the same
    /// signal gets it too).
    pub(super) fn mail(
        &mut self,
        mailbox: MailboxId,
        connection: ConnId,
        payload: Payload,
    ) -> Result<(), &'static str> {
        let Some(mail) = self.mailboxes.get_mut(&mailbox) else {
            return Ok(());
        };
        let bytes = super::delivery::queued_bytes(&payload.0);
        mail.queue.push((connection, payload), bytes)?;
        if mail.waiter.is_none() {
            return Ok(());
        }
        let Some(core) = self.core.upgrade() else {
            return Ok(());
        };
        let task_core = core.clone();
        self.spawn(Box::pin(async move {
            task_core.with(|st| st.wake_for_mail(mailbox));
        }));
        Ok(())
    }

    /// Ends the program's wait with the first delivery in its mailbox, if it
    /// still waits.
    fn wake_for_mail(&mut self, mailbox: MailboxId) {
        let Some(mail) = self.mailboxes.get_mut(&mailbox) else {
            return;
        };
        let (Some(w), false) = (mail.waiter, mail.queue.is_empty()) else {
            return;
        };
        mail.waiter = None;
        let delivery = mail.queue.pop_front();
        let Some(waiter) = self.waiters.remove(&w) else {
            return;
        };
        if let Some(task) = waiter.timeout_task {
            self.cancelled.push(task);
        }
        // The wait's own signal connection ends with it.
        if let Some(connection) = waiter.connection {
            self.disconnect(connection, "closed");
        }
        if let (WaiterReply::Wait { reply, .. }, Some((connection, payload))) =
            (waiter.reply, delivery)
        {
            let woke = Woke::Delivery(connection, payload);
            self.resume(
                waiter.lockstep,
                Box::new(move || reply.send(Ok(woke)).is_ok()),
            );
        }
    }
}
