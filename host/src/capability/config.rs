//! `radar:reactive/config`: the values the system gives the plugin (a
//! manifest's `config` table, the builder's `config` calls), as text.

use std::collections::BTreeMap;
use std::sync::Arc;

use wasmtime::component::{HasSelf, Linker};

use super::bindings::radar::reactive::config::{self, Host};
use crate::script::SCRIPT_KEY;

/// What config reaches: the plugin's values, shared by its instances, and
/// for a development runtime its script ([`crate::script`]), read under
/// [`SCRIPT_KEY`] but not listed by `keys`.
pub(crate) struct ConfigState {
    pub values: Arc<BTreeMap<String, String>>,
    pub script: Option<Arc<str>>,
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
        match &self.script {
            Some(script) if key == SCRIPT_KEY => Some(script.to_string()),
            _ => self.values.get(&key).cloned(),
        }
    }

    fn keys(&mut self) -> Vec<String> {
        self.values.keys().cloned().collect()
    }
}
