//! `radar:reactive/config`: the values the system gives the plugin (a
//! manifest's `config` table, the builder's `config` calls), as text.

use std::collections::BTreeMap;
use std::sync::Arc;

use wasmtime::component::{HasSelf, Linker};

use super::bindings::radar::reactive::config::{self, Host};
use crate::plugin::PluginCtx;

/// What config reaches: the plugin's values, shared by its instances.
pub(crate) struct ConfigState(pub Arc<BTreeMap<String, String>>);

pub(crate) fn add_to_linker(linker: &mut Linker<PluginCtx>) -> wasmtime::Result<()> {
    config::add_to_linker::<PluginCtx, HasSelf<ConfigState>>(linker, |ctx| &mut ctx.config)
}

impl Host for ConfigState {
    fn get(&mut self, key: String) -> Option<String> {
        self.0.get(&key).cloned()
    }

    fn keys(&mut self) -> Vec<String> {
        self.0.keys().cloned().collect()
    }
}
