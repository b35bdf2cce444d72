//! The blackboard's state (see `capability::board`): every entry any
//! plugin declares, its type and its value. Plugins reach it from inside
//! their calls, deliberative code through commands; every write is recorded
//! (`board-write`, with who wrote it).

use std::collections::{BTreeMap, BTreeSet};

use serde_json::Value as Json;
use wasmtime::component::Val;

use crate::capability::board::{Access, BoardPort};
use crate::error::RadarError;
use crate::payload::{json_to_val, PayloadType};

/// What a plugin may do with the blackboard (manifest: `board = { read =
/// [...], write = [...] }`); nothing by default.
#[derive(Clone, Debug, Default)]
pub(crate) struct Grants {
    pub read: BTreeSet<String>,
    pub write: BTreeSet<String>,
}

impl Grants {
    fn allows(&self, access: Access, entry: &str) -> bool {
        match access {
            Access::Read => self.read.contains(entry),
            Access::Write => self.write.contains(entry),
        }
    }
}

/// The entries and their values.
pub(crate) struct Blackboard {
    entries: BTreeMap<String, (PayloadType, Option<Val>)>,
}

impl Blackboard {
    pub(super) fn new(types: BTreeMap<String, PayloadType>) -> Self {
        Self {
            entries: types.into_iter().map(|(e, t)| (e, (t, None))).collect(),
        }
    }
}

/// Checks what a plugin's ports do against its grants and the entries'
/// types; the error names the plugin, the entry and the fix.
fn check_ports(
    plugin: &str,
    ports: &[BoardPort],
    grants: &Grants,
    types: &BTreeMap<String, PayloadType>,
) -> Result<(), String> {
    for port in ports {
        if !grants.allows(port.access, &port.entry) {
            return Err(format!(
                "plugin `{plugin}` {}s entry `{}` without a grant (give it \
                 `board = {{ {} = [\"{}\"] }}` in its manifest table)",
                port.access.as_str(),
                port.entry,
                port.access.as_str(),
                port.entry
            ));
        }
        if let Some(ty) = types.get(&port.entry) {
            if *ty != port.ty {
                return Err(format!(
                    "plugin `{plugin}` {}s entry `{}` as {}, but it is {}",
                    port.access.as_str(),
                    port.entry,
                    port.ty,
                    ty
                ));
            }
        }
    }
    Ok(())
}

/// A plugin as the blackboard sees it: its name, its ports, its grants.
pub(crate) struct BoardUser<'a> {
    pub name: &'a str,
    pub ports: &'a [BoardPort],
    pub grants: &'a Grants,
}

/// The blackboard of a system of `plugins`: each entry with the one type
/// every plugin using it agrees on. Refuses a port without a grant, two
/// types for one entry, and a grant of an entry nobody uses.
pub(crate) fn plan(plugins: &[BoardUser<'_>]) -> Result<BTreeMap<String, PayloadType>, RadarError> {
    let mut types: BTreeMap<String, (PayloadType, String)> = BTreeMap::new();
    for def in plugins {
        for port in def.ports.iter() {
            match types.get(&port.entry) {
                Some((ty, first)) if *ty != port.ty => {
                    return Err(RadarError::Blackboard(format!(
                        "entry `{}` is {} for `{first}` but {} for `{}`",
                        port.entry, ty, port.ty, def.name
                    )))
                }
                Some(_) => {}
                None => {
                    types.insert(port.entry.clone(), (port.ty.clone(), def.name.to_string()));
                }
            }
        }
    }
    let types: BTreeMap<String, PayloadType> =
        types.into_iter().map(|(e, (t, _))| (e, t)).collect();
    for def in plugins {
        check_ports(def.name, def.ports, def.grants, &types).map_err(RadarError::Blackboard)?;
        for (access, entries) in [("read", &def.grants.read), ("write", &def.grants.write)] {
            if let Some(unknown) = entries.iter().find(|e| !types.contains_key(*e)) {
                return Err(RadarError::Blackboard(format!(
                    "plugin `{}` is granted {access} of entry `{unknown}`, which no plugin \
                     reads or writes (entries: {})",
                    def.name,
                    if types.is_empty() {
                        "none".to_string()
                    } else {
                        types.keys().cloned().collect::<Vec<_>>().join(", ")
                    }
                )));
            }
        }
    }
    Ok(types)
}

impl Blackboard {
    /// Whether a new version of plugin `plugin` (granted `grants`) keeps to
    /// its grants and to the entries' types.
    pub(super) fn check_version(
        &self,
        plugin: &str,
        ports: &[BoardPort],
        grants: &Grants,
    ) -> Result<(), String> {
        let types: BTreeMap<String, PayloadType> = self
            .entries
            .iter()
            .map(|(e, (t, _))| (e.clone(), t.clone()))
            .collect();
        check_ports(plugin, ports, grants, &types)?;
        match ports.iter().find(|p| !types.contains_key(&p.entry)) {
            Some(port) => Err(format!(
                "the new version uses entry `{}`, which this system's blackboard does not have",
                port.entry
            )),
            None => Ok(()),
        }
    }

    /// The value of `entry`, if written.
    pub(super) fn read(&self, entry: &str) -> Option<Val> {
        self.entries.get(entry).and_then(|(_, value)| value.clone())
    }

    /// Sets `entry` (one the board has) to `value`; whether it has it.
    pub(super) fn set(&mut self, entry: &str, value: Val) -> bool {
        match self.entries.get_mut(entry) {
            Some((_, slot)) => {
                *slot = Some(value);
                true
            }
            None => false,
        }
    }

    /// `json` as a value of `entry`'s type.
    pub(super) fn value(&self, entry: &str, json: &Json) -> Result<Val, RadarError> {
        let ty = self.type_of(entry)?;
        json_to_val(json, &ty)
            .map_err(|cause| RadarError::Blackboard(format!("entry `{entry}` is {ty}: {cause}")))
    }

    /// `entry`'s type, or the error that lists the entries there are.
    pub(super) fn type_of(&self, entry: &str) -> Result<PayloadType, RadarError> {
        self.entries
            .get(entry)
            .map(|(ty, _)| ty.clone())
            .ok_or_else(|| {
                RadarError::Blackboard(format!(
                    "no plugin reads or writes entry `{entry}` (entries: {})",
                    if self.entries.is_empty() {
                        "none".to_string()
                    } else {
                        self.entries.keys().cloned().collect::<Vec<_>>().join(", ")
                    }
                ))
            })
    }
}
