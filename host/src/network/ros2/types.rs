//! Where message definitions come from, and what each becomes for Radar:
//! the definitions built in ([`super::builtin`]) and those in the
//! manifest's `[ros2] msg_paths`, a type with every type it refers to, its
//! RIHS01 hash, and the WIT type its values take on the blackboard and in
//! signals.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::builtin::BUILTIN;
use super::error::TypeError;
use super::hash::rihs01;
use super::msg::{self, Base, MessageDef, Primitive, Shape};
use crate::payload::PayloadType;

/// Finds message definitions: in `msg_paths` first (folders holding
/// `<pkg>/msg/<Name>.msg`, as a ROS 2 install's `share` does), then among
/// the built-in ones.
#[derive(Clone, Debug, Default)]
pub struct MessageTypes {
    paths: Vec<PathBuf>,
}

/// A message type, ready for the wire.
#[derive(Clone, Debug)]
pub struct Message {
    /// `pkg/msg/Name`.
    pub name: String,
    /// `RIHS01_…`.
    pub hash: String,
    /// Its definition and those of every type it refers to, by name.
    pub defs: BTreeMap<String, MessageDef>,
}

impl MessageTypes {
    /// Definitions from `paths` before the built-in ones.
    pub fn new(paths: Vec<PathBuf>) -> Self {
        Self { paths }
    }

    /// Every built-in type's name.
    pub fn builtin_names() -> impl Iterator<Item = &'static str> {
        BUILTIN.iter().map(|(name, _)| *name)
    }

    /// Type `name` (`pkg/msg/Name`) with everything it refers to; the
    /// error names the type that is missing or cannot be read.
    pub fn load(&self, name: &str) -> Result<Message, TypeError> {
        self.load_type(name).map_err(TypeError)
    }

    fn load_type(&self, name: &str) -> Result<Message, String> {
        if !msg::is_type_name(name) {
            return Err(format!(
                "`{name}` is not a message type (expected `package/msg/Name`, e.g. \
                 `sensor_msgs/msg/Range`)"
            ));
        }
        let mut defs = BTreeMap::new();
        let mut stack = vec![name.to_string()];
        while let Some(next) = stack.pop() {
            if defs.contains_key(&next) {
                continue;
            }
            let def = self.definition(&next).map_err(|e| {
                if next == name {
                    e
                } else {
                    format!("{e} (used by {name})")
                }
            })?;
            for field in &def.fields {
                if let Base::Nested(nested) = &field.base {
                    stack.push(nested.clone());
                }
            }
            defs.insert(next, def);
        }
        refuse_cycles(name, &defs, &mut Vec::new())?;
        Ok(Message {
            name: name.to_string(),
            hash: rihs01(name, &defs),
            defs,
        })
    }

    fn definition(&self, name: &str) -> Result<MessageDef, String> {
        let mut parts = name.split('/');
        let (package, file) = match (parts.next(), parts.next(), parts.next()) {
            (Some(p), Some(_), Some(n)) => (p, format!("{n}.msg")),
            _ => return Err(format!("`{name}` is not a message type")),
        };
        for dir in &self.paths {
            for candidate in candidates(dir, package, &file) {
                if candidate.is_file() {
                    let text = std::fs::read_to_string(&candidate)
                        .map_err(|e| format!("cannot read {}: {e}", candidate.display()))?;
                    return msg::parse(name, &text)
                        .map_err(|e| format!("{} ({})", e, candidate.display()));
                }
            }
        }
        match BUILTIN.binary_search_by(|(n, _)| (*n).cmp(name)) {
            Ok(i) => msg::parse(name, BUILTIN[i].1),
            Err(_) => Err(format!(
                "unknown message type `{name}`: not built in{} (add its .msg file's folder to \
                 [ros2] msg_paths)",
                if self.paths.is_empty() {
                    String::new()
                } else {
                    format!(
                        ", and no {package}/msg/{file} under {}",
                        self.paths
                            .iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                }
            )),
        }
    }
}

/// A type that contains itself, through any number of others, has no
/// finite form: refused, naming the loop.
fn refuse_cycles(
    name: &str,
    defs: &BTreeMap<String, MessageDef>,
    path: &mut Vec<String>,
) -> Result<(), String> {
    if path.iter().any(|p| p == name) {
        path.push(name.to_string());
        return Err(format!(
            "message types that contain themselves: {}",
            path.join(" → ")
        ));
    }
    path.push(name.to_string());
    for field in &defs[name].fields {
        if let Base::Nested(nested) = &field.base {
            refuse_cycles(nested, defs, path)?;
        }
    }
    path.pop();
    Ok(())
}

/// `<dir>/<pkg>/msg/<Name>.msg` (a `share` folder), or `<dir>/msg/<Name>.msg`
/// when `dir` is the package itself.
fn candidates(dir: &Path, package: &str, file: &str) -> Vec<PathBuf> {
    let mut found = vec![dir.join(package).join("msg").join(file)];
    if dir.file_name().and_then(|n| n.to_str()) == Some(package) {
        found.push(dir.join("msg").join(file));
    }
    found
}

impl Message {
    /// This type's own definition.
    pub fn def(&self) -> &MessageDef {
        &self.defs[&self.name]
    }

    /// The WIT type a value of this message takes: a record with a field
    /// for each of the message's, named in WIT's way (`frame_id` is
    /// `frame-id`).
    pub fn payload_type(&self) -> PayloadType {
        self.record_type(&self.name)
    }

    pub(super) fn record_type(&self, name: &str) -> PayloadType {
        PayloadType::Record(
            self.defs[name]
                .fields
                .iter()
                .map(|f| (wit_name(&f.name), self.field_type(&f.base, f.shape)))
                .collect(),
        )
    }

    pub(super) fn field_type(&self, base: &Base, shape: Shape) -> PayloadType {
        let element = match base {
            Base::Primitive(p) => primitive_type(*p),
            Base::String { .. } => PayloadType::String,
            Base::Nested(name) => self.record_type(name),
        };
        match shape {
            Shape::One => element,
            _ => PayloadType::List(Box::new(element)),
        }
    }
}

/// A ROS field name as WIT spells it.
pub fn wit_name(field: &str) -> String {
    field.replace('_', "-")
}

pub(super) fn primitive_type(p: Primitive) -> PayloadType {
    match p {
        Primitive::Bool => PayloadType::Bool,
        Primitive::Byte | Primitive::Char | Primitive::U8 => PayloadType::U8,
        Primitive::I8 => PayloadType::S8,
        Primitive::I16 => PayloadType::S16,
        Primitive::U16 => PayloadType::U16,
        Primitive::I32 => PayloadType::S32,
        Primitive::U32 => PayloadType::U32,
        Primitive::I64 => PayloadType::S64,
        Primitive::U64 => PayloadType::U64,
        Primitive::F32 => PayloadType::F32,
        Primitive::F64 => PayloadType::F64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_type_loads_with_what_it_refers_to() {
        let types = MessageTypes::default();
        for name in MessageTypes::builtin_names() {
            let message = types.load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(message.hash.starts_with("RIHS01_") && message.hash.len() == 71);
        }
        let range = types.load("sensor_msgs/msg/Range").expect("works");
        assert!(range.defs.contains_key("builtin_interfaces/msg/Time"));
        assert_eq!(
            range.payload_type().to_string(),
            "record { header: record { stamp: record { sec: s32, nanosec: u32 }, frame-id: \
             string }, radiation-type: u8, field-of-view: f32, min-range: f32, max-range: f32, \
             range: f32, variance: f32 }"
        );
    }

    #[test]
    fn names_a_missing_type_and_who_uses_it() {
        let dir = std::env::temp_dir().join(format!("radar-msg-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("my_msgs/msg")).expect("works");
        std::fs::write(
            dir.join("my_msgs/msg/Probe.msg"),
            "Missing thing\nfloat32 x\n",
        )
        .expect("works");
        let types = MessageTypes::new(vec![dir.clone()]);
        let e = types.load("my_msgs/msg/Probe").expect_err("is refused");
        assert!(
            e.0.contains("unknown message type `my_msgs/msg/Missing`") && e.0.contains("used by"),
            "{e}"
        );
        std::fs::write(dir.join("my_msgs/msg/Loop.msg"), "Loop[] more\n").expect("works");
        let e = types.load("my_msgs/msg/Loop").expect_err("is refused");
        assert!(
            e.0.contains("contain themselves: my_msgs/msg/Loop → my_msgs/msg/Loop"),
            "{e}"
        );
        let e = types.load("nope").expect_err("is refused");
        assert!(e.0.contains("not a message type"), "{e}");
        let _ = std::fs::remove_dir_all(dir);
    }
}
