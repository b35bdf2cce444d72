//! The blackboard's state (see `capability::board`): every entry any
//! plugin declares, its type and its value. Plugins reach it from inside
//! their calls, deliberative code through commands; every write is recorded
//! (`board-write`, with who wrote it).

use std::collections::{BTreeMap, BTreeSet};

use super::*;
use crate::capability::board::{Access, BoardPort};

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

/// The blackboard of a system of `plugins`: each entry with the one type
/// every plugin using it agrees on. Refuses a port without a grant, two
/// types for one entry, and a grant of an entry nobody uses.
pub(crate) fn plan(plugins: &[PluginDef]) -> Result<BTreeMap<String, PayloadType>, RadarError> {
    let mut types: BTreeMap<String, (PayloadType, String)> = BTreeMap::new();
    for def in plugins {
        for port in def.code.board.iter() {
            match types.get(&port.entry) {
                Some((ty, first)) if *ty != port.ty => {
                    return Err(RadarError::Blackboard(format!(
                        "entry `{}` is {} for `{first}` but {} for `{}`",
                        port.entry, ty, port.ty, def.name
                    )))
                }
                Some(_) => {}
                None => {
                    types.insert(port.entry.clone(), (port.ty.clone(), def.name.clone()));
                }
            }
        }
    }
    let types: BTreeMap<String, PayloadType> =
        types.into_iter().map(|(e, (t, _))| (e, t)).collect();
    for def in plugins {
        check_ports(&def.name, &def.code.board, &def.grants, &types)
            .map_err(RadarError::Blackboard)?;
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

impl State {
    /// Whether a new version of plugin `pid` keeps to its grants and to the
    /// entries' types.
    pub(super) fn check_board(&self, pid: usize, ports: &[BoardPort]) -> Result<(), String> {
        let entry = &self.plugins[pid];
        let types: BTreeMap<String, PayloadType> = self
            .board
            .entries
            .iter()
            .map(|(e, (t, _))| (e.clone(), t.clone()))
            .collect();
        check_ports(&entry.def.name, ports, &entry.def.grants, &types)?;
        match ports.iter().find(|p| !types.contains_key(&p.entry)) {
            Some(port) => Err(format!(
                "the new version uses entry `{}`, which this system's blackboard does not have",
                port.entry
            )),
            None => Ok(()),
        }
    }

    /// Writes `value` into `entry` and records it, `by` a plugin or
    /// `(native)`.
    pub(super) fn board_write(&mut self, by: &str, entry: &str, value: Val) {
        if let Some((_, slot)) = self.board.entries.get_mut(entry) {
            let json = trace_json(&value);
            *slot = Some(value);
            self.record(Entry::BoardWrite {
                entry: entry.to_string(),
                by: Arc::from(by),
                value: json,
            });
        }
    }

    /// The value of `entry`, if written.
    pub(super) fn board_read(&self, entry: &str) -> Option<Val> {
        self.board
            .entries
            .get(entry)
            .and_then(|(_, value)| value.clone())
    }

    /// `json` as a value of `entry`'s type.
    pub(super) fn board_value(&self, entry: &str, json: &Json) -> Result<Val, RadarError> {
        let ty = self.board_type(entry)?;
        json_to_val(json, &ty)
            .map_err(|cause| RadarError::Blackboard(format!("entry `{entry}` is {ty}: {cause}")))
    }

    pub(super) fn board_type(&self, entry: &str) -> Result<PayloadType, RadarError> {
        self.board
            .entries
            .get(entry)
            .map(|(ty, _)| ty.clone())
            .ok_or_else(|| {
                RadarError::Blackboard(format!(
                    "no plugin reads or writes entry `{entry}` (entries: {})",
                    if self.board.entries.is_empty() {
                        "none".to_string()
                    } else {
                        self.board
                            .entries
                            .keys()
                            .cloned()
                            .collect::<Vec<_>>()
                            .join(", ")
                    }
                ))
            })
    }
}
