//! `radar:reactive/config`: the values the system gives the plugin (a
//! manifest's `config` table, the builder's `config` calls), as text.
//!
//! A plugin's values can change while it runs (a ROS 2 parameter set, a
//! `configure` input: `docs/manifest.md#config`): each read sees them as
//! they are at that moment, as a blackboard read does. That is the same
//! place in a replay and with `--threads`: a change is made by the
//! scheduler between its tasks' polls, never while a call computes, and a
//! read happens inside a poll. A plugin on an agent gets the values with
//! each call and each wake (`crate::plugin::remote`), the points where its
//! call can have waited while a change was made.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use wasmtime::component::{HasSelf, Linker};

use super::bindings::radar::reactive::config::{self, Host};
use crate::script::SCRIPT_KEY;

/// A plugin's config values as they are now: one for the plugin, shared
/// by each instance it makes (a swap's and a reset's too), changed by the
/// scheduler when it applies a `configure` input. Every set and read
/// happens on the scheduler's thread or during a poll it waits for; the
/// lock and the atomic make it `Sync`, as a store's state must be.
#[derive(Debug)]
pub(crate) struct LiveConfig {
    /// Bumped by every change, so that a call sees one cheaply.
    version: AtomicU64,
    values: Mutex<Arc<BTreeMap<String, String>>>,
}

impl LiveConfig {
    pub(crate) fn new(values: BTreeMap<String, String>) -> Self {
        Self {
            version: AtomicU64::new(0),
            values: Mutex::new(Arc::new(values)),
        }
    }

    /// The values now, and their version.
    pub(crate) fn current(&self) -> (u64, Arc<BTreeMap<String, String>>) {
        let values = self.values.lock().unwrap_or_else(PoisonError::into_inner);
        (self.version.load(Ordering::Acquire), values.clone())
    }

    /// The values, if they changed since version `seen` (which becomes
    /// theirs): what a reader that keeps a copy takes.
    pub(crate) fn changed_since(&self, seen: &mut u64) -> Option<Arc<BTreeMap<String, String>>> {
        if self.version.load(Ordering::Acquire) == *seen {
            return None;
        }
        let (version, values) = self.current();
        *seen = version;
        Some(values)
    }

    /// Sets `key` to `value`.
    pub(crate) fn set(&self, key: &str, value: &str) {
        let mut values = self.values.lock().unwrap_or_else(PoisonError::into_inner);
        Arc::make_mut(&mut values).insert(key.to_string(), value.to_string());
        self.version.fetch_add(1, Ordering::AcqRel);
    }

    /// Replaces every value (an agent told of a change by its coordinator).
    pub(crate) fn replace(&self, new: BTreeMap<String, String>) {
        let mut values = self.values.lock().unwrap_or_else(PoisonError::into_inner);
        *values = Arc::new(new);
        self.version.fetch_add(1, Ordering::AcqRel);
    }
}

/// What config reaches: the plugin's values (taken from its
/// [`LiveConfig`] when they changed, if it has one), and for a
/// development runtime its script ([`crate::script`]), read under
/// [`SCRIPT_KEY`] but not listed by `keys`.
pub(crate) struct ConfigState {
    values: Arc<BTreeMap<String, String>>,
    live: Option<(Arc<LiveConfig>, u64)>,
    script: Option<Arc<str>>,
}

impl ConfigState {
    /// Values that never change (a deliberative program's).
    pub(crate) fn fixed(values: Arc<BTreeMap<String, String>>, script: Option<Arc<str>>) -> Self {
        Self {
            values,
            live: None,
            script,
        }
    }

    /// A plugin's values, as `live` has them now and after each change.
    pub(crate) fn live(live: Arc<LiveConfig>, script: Option<Arc<str>>) -> Self {
        let (version, values) = live.current();
        Self {
            values,
            live: Some((live, version)),
            script,
        }
    }

    /// The values now: the live ones, if they changed since last read.
    fn refresh(&mut self) {
        if let Some(values) = self
            .live
            .as_mut()
            .and_then(|(live, seen)| live.changed_since(seen))
        {
            self.values = values;
        }
    }
}

/// Config's view of a store's state.
pub(crate) trait ConfigView: Send + 'static {
    /// The store's configuration.
    fn config(&mut self) -> &mut ConfigState;
}

pub(crate) fn add_to_linker<T: ConfigView>(linker: &mut Linker<T>) -> wasmtime::Result<()> {
    config::add_to_linker::<T, HasSelf<ConfigState>>(linker, T::config)
}

impl Host for ConfigState {
    fn get(&mut self, key: String) -> Option<String> {
        self.refresh();
        match &self.script {
            Some(script) if key == SCRIPT_KEY => Some(script.to_string()),
            _ => self.values.get(&key).cloned(),
        }
    }

    fn keys(&mut self) -> Vec<String> {
        self.refresh();
        self.values.keys().cloned().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_read_sees_the_values_as_they_are_at_that_moment() {
        let live = Arc::new(LiveConfig::new(BTreeMap::from([(
            "threshold".to_string(),
            "0.5".to_string(),
        )])));
        let mut state = ConfigState::live(live.clone(), None);
        assert_eq!(state.get("threshold".into()).as_deref(), Some("0.5"));
        live.set("threshold", "0.3");
        live.set("mode", "careful");
        assert_eq!(state.get("threshold".into()).as_deref(), Some("0.3"));
        assert_eq!(state.keys(), ["mode", "threshold"]);
    }
}
