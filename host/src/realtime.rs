//! The scheduler's thread as robot programmers tune it for real time
//! (Linux): timer slack, a real-time priority (`SCHED_FIFO`) and a CPU of
//! its own.
//!
//! Under the real clock the thread that runs the scheduler (the one that
//! calls [`crate::System::run`]) always gets a timer slack of 1 ns for the
//! run, so that its sleeps end when asked rather than up to the kernel's
//! default 50 µs later. On request it also runs at a `SCHED_FIFO`
//! priority, so that other processes (a compile, a logger) cannot delay a
//! deadline, and pinned to one CPU. Everything is put back when the run
//! ends. Only the scheduler's thread changes: plugins run on it; native
//! deliberative code runs on threads of its own.

use std::num::NonZeroU64;

use thread_priority::{
    RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue, ThreadSchedulePolicy,
};

use crate::clock::ClockKind;
use crate::error::RadarError;

/// Real-time settings of a run (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RealTime {
    /// `SCHED_FIFO` priority, 1 (lowest) to 99.
    pub priority: Option<u8>,
    /// The CPU the scheduler's thread is pinned to.
    pub cpu: Option<usize>,
}

/// What [`enter`] changed, put back when dropped.
pub(crate) struct Entered {
    slack: Option<u64>,
    policy: Option<(ThreadSchedulePolicy, i32)>,
    affinity: Option<rustix::thread::CpuSet>,
}

/// Applies `settings` (and, under the real clock, a 1 ns timer slack) to
/// the calling thread, the scheduler's.
pub(crate) fn enter(clock: ClockKind, settings: RealTime) -> Result<Entered, RadarError> {
    let mut entered = Entered {
        slack: None,
        policy: None,
        affinity: None,
    };
    if clock == ClockKind::Real {
        if let Ok(previous) = rustix::thread::current_timer_slack() {
            if rustix::thread::set_current_timer_slack(NonZeroU64::new(1)).is_ok() {
                entered.slack = Some(previous);
            }
        }
    }
    if let Some(cpu) = settings.cpu {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let previous = rustix::thread::sched_getaffinity(None).ok();
        let mut only = rustix::thread::CpuSet::new();
        if cpu >= rustix::thread::CpuSet::MAX_CPU {
            return Err(RadarError::RealTime(format!(
                "no CPU {cpu} to pin the scheduler to (this machine has {cpus})"
            )));
        }
        only.set(cpu);
        rustix::thread::sched_setaffinity(None, &only).map_err(|e| {
            RadarError::RealTime(format!(
                "cannot pin the scheduler to CPU {cpu} (this machine has {cpus}, numbered from 0): {e}"
            ))
        })?;
        entered.affinity = previous;
    }
    if let Some(priority) = settings.priority {
        let thread = thread_priority::thread_native_id();
        let previous = thread_priority::unix::thread_schedule_policy_param(thread)
            .ok()
            .map(|(policy, params)| (policy, params.sched_priority));
        let value = ThreadPriorityValue::try_from(priority)
            .ok()
            .filter(|_| (1..=99).contains(&priority))
            .ok_or_else(|| {
                RadarError::RealTime(format!(
                    "real-time priority {priority}: expected 1 (lowest) to 99"
                ))
            })?;
        thread_priority::unix::set_thread_priority_and_policy(
            thread,
            ThreadPriority::Crossplatform(value),
            ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
        )
        .map_err(|e| {
            RadarError::RealTime(format!(
                "cannot run the scheduler at real-time priority {priority} (SCHED_FIFO): {e}; \
                 it needs CAP_SYS_NICE (`sudo setcap cap_sys_nice+ep $(which radar)`) or an \
                 RLIMIT_RTPRIO of at least {priority} (`ulimit -r`; in \
                 /etc/security/limits.conf: `USER - rtprio {priority}`)"
            ))
        })?;
        entered.policy = previous;
    }
    Ok(entered)
}

impl Drop for Entered {
    fn drop(&mut self) {
        if let Some((policy, priority)) = self.policy.take() {
            let thread = thread_priority::thread_native_id();
            let priority = ThreadPriority::from_posix(thread_priority::unix::ScheduleParams {
                sched_priority: priority,
            });
            let _ = thread_priority::unix::set_thread_priority_and_policy(thread, priority, policy);
        }
        if let Some(affinity) = self.affinity.take() {
            let _ = rustix::thread::sched_setaffinity(None, &affinity);
        }
        if let Some(slack) = self.slack.take() {
            let _ = rustix::thread::set_current_timer_slack(NonZeroU64::new(slack));
        }
    }
}
