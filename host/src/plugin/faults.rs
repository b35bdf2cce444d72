//! Faults put into a run on purpose: a trap or fuel exhaustion at a
//! plugin's n-th call, a failed n-th instantiation (a reset, a swap's new
//! version). A seeded simulation (`radar test --simulate`) and a scenario's
//! `[[fault]]` tables use them to show what the system does when a plugin
//! fails, at a point that does not depend on the machine.
//!
//! They are counted where every call and every instance of a plugin
//! passes, whatever its language or where it runs, so an injected fault
//! takes the same path as one of the plugin's own: the plugin faults, its
//! store is given up, and the trace says why.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use super::call::Fault;

/// What goes wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FaultKind {
    /// The call traps.
    Trap,
    /// The call runs out of fuel.
    Fuel,
    /// The call fails on its memory limit (`memory_bytes`).
    Memory,
    /// The instantiation fails (the run's start, a reset, a fresh store
    /// for a `start` that ignored a request to stop; not a swap's new
    /// version, nor the fresh instance an exit after a fault runs on).
    Instantiation,
    /// The fresh instance the exit after a fault runs on cannot be made
    /// (`at`: the plugin's n-th exit after a fault).
    ExitInstantiation,
}

impl FaultKind {
    /// How `scenario.toml` names it: `trap`, `fuel`, `reset-fails`.
    pub fn as_str(self) -> &'static str {
        match self {
            FaultKind::Trap => "trap",
            FaultKind::Fuel => "fuel",
            FaultKind::Memory => "memory",
            FaultKind::Instantiation => "reset-fails",
            FaultKind::ExitInstantiation => "exit-instance-fails",
        }
    }
}

/// One fault to inject into a plugin.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct InjectedFault {
    /// What goes wrong.
    pub kind: FaultKind,
    /// At which call ([`FaultKind::Trap`], [`FaultKind::Fuel`]) or
    /// instantiation ([`FaultKind::Instantiation`]), counted from 1 over
    /// all the plugin's instances (the first instantiation is the run's
    /// start; then each reset, and each fresh store after a store died; a
    /// swap's new version is not counted).
    pub at: u64,
    /// The plugin is reset this long after the fault, as an operator or a
    /// supervisor would (none: it stays in `error`).
    pub reset_after: Option<Duration>,
}

/// A plugin's counts of calls and instantiations, over all its instances,
/// and the faults planned for it.
#[derive(Debug, Default)]
pub(crate) struct FaultPlan {
    calls: AtomicU64,
    instantiations: AtomicU64,
    exit_instantiations: AtomicU64,
    faults: Vec<InjectedFault>,
}

impl FaultPlan {
    /// A plan with these faults (none: only counting).
    pub fn new(faults: Vec<InjectedFault>) -> Self {
        Self {
            faults,
            ..Self::default()
        }
    }

    /// Calls made so far.
    pub fn calls(&self) -> u64 {
        self.calls.load(Ordering::Relaxed)
    }

    /// Instances made so far (or tried).
    pub fn instantiations(&self) -> u64 {
        self.instantiations.load(Ordering::Relaxed)
    }

    /// Whether a call of the plugin may end with a planned fault.
    pub fn plans_call_faults(&self) -> bool {
        self.faults.iter().any(|f| {
            matches!(
                f.kind,
                FaultKind::Trap | FaultKind::Fuel | FaultKind::Memory
            )
        })
    }

    /// Counts a call; the fault it is to end with, if one is planned.
    pub fn on_call(&self) -> Option<Fault> {
        let n = self.calls.fetch_add(1, Ordering::Relaxed) + 1;
        if self.faults.is_empty() {
            return None;
        }
        let planned = self.faults.iter().find(|f| {
            f.at == n
                && matches!(
                    f.kind,
                    FaultKind::Trap | FaultKind::Fuel | FaultKind::Memory
                )
        })?;
        let mut fault = match planned.kind {
            FaultKind::Fuel => {
                let mut fault =
                    Fault::new(format!("fuel exhausted (injected fault at its call {n})"));
                fault.out_of_fuel = true;
                fault
            }
            FaultKind::Memory => Fault::new(format!(
                "memory: a growth over its limit (`memory_bytes`): injected fault at its call {n}"
            )),
            _ => Fault::new(format!("trapped: injected fault at its call {n}")),
        };
        fault.reset_after = planned.reset_after;
        Some(fault)
    }

    /// Counts an instantiation; the fault it is to fail with, if one is
    /// planned.
    pub fn on_instantiation(&self) -> Option<Fault> {
        let n = self.instantiations.fetch_add(1, Ordering::Relaxed) + 1;
        let planned = self
            .faults
            .iter()
            .find(|f| f.at == n && f.kind == FaultKind::Instantiation)?;
        let mut fault = Fault::new(format!(
            "instantiation failed: injected fault at its instantiation {n}"
        ));
        fault.reset_after = planned.reset_after;
        Some(fault)
    }

    /// Counts a fresh instance made for an exit after a fault; the fault
    /// it is to fail with, if one is planned.
    pub fn on_exit_instantiation(&self) -> Option<Fault> {
        let n = self.exit_instantiations.fetch_add(1, Ordering::Relaxed) + 1;
        let planned = self
            .faults
            .iter()
            .find(|f| f.at == n && f.kind == FaultKind::ExitInstantiation)?;
        let mut fault = Fault::new(format!(
            "instantiation failed: injected fault at its exit after a fault {n}"
        ));
        fault.reset_after = planned.reset_after;
        Some(fault)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faults_come_at_their_call_and_instantiation() {
        let plan = FaultPlan::new(vec![
            InjectedFault {
                kind: FaultKind::Trap,
                at: 2,
                reset_after: Some(Duration::from_millis(5)),
            },
            InjectedFault {
                kind: FaultKind::Fuel,
                at: 4,
                reset_after: None,
            },
            InjectedFault {
                kind: FaultKind::Instantiation,
                at: 2,
                reset_after: None,
            },
        ]);
        assert!(plan.on_call().is_none());
        let trap = plan.on_call().expect("the second call traps");
        assert!(
            trap.cause.contains("call 2") && !trap.out_of_fuel,
            "{}",
            trap.cause
        );
        assert_eq!(trap.reset_after, Some(Duration::from_millis(5)));
        assert!(plan.on_call().is_none());
        assert!(plan.on_call().expect("fuel").out_of_fuel);
        assert_eq!(plan.calls(), 4);
        assert!(plan.on_instantiation().is_none());
        assert!(plan.on_instantiation().is_some());
        assert!(plan.on_instantiation().is_none());
    }
}
