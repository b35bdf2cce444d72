//! Whether a message fits a blackboard entry or a signal, and how values
//! move between them: checked once when the system is built, so that a
//! mismatch is refused before anything runs, naming the field and both
//! types.
//!
//! An entry takes the whole message, one field of it (`field = "range"`,
//! `field = "header.stamp"`), or a record of some of its fields (`record {
//! percentage: f32 }` of a `BatteryState`): what it leaves out is not
//! kept. A message of one field (`std_msgs/msg/Float32`) fits an entry of
//! that field's type as it is. A signal fills a message the same ways, the
//! fields it leaves out taking the route's `values` or their zero value.

use serde_json::{Map, Value as Json};

use super::msg::Base;
use super::types::{wit_name, Message};
use crate::payload::PayloadType;

/// A field inside a message, as WIT names (empty: the whole message).
pub type FieldPath = Vec<String>;

/// Reads `field = "a.b_c"` (ROS or WIT spelling) as a path into `message`
/// and the WIT type found there.
pub fn field_path(message: &Message, text: &str) -> Result<(FieldPath, PayloadType), String> {
    let path: FieldPath = text.split('.').map(wit_name).collect();
    let mut ty = message.payload_type();
    for (depth, key) in path.iter().enumerate() {
        let PayloadType::Record(fields) = &ty else {
            return Err(format!(
                "`{text}`: `{}` is {ty}, which has no fields",
                path[..depth].join(".")
            ));
        };
        ty = match fields.iter().find(|(name, _)| name == key) {
            Some((_, t)) => t.clone(),
            None => {
                return Err(format!(
                    "{} has no field `{}` (its fields: {})",
                    if depth == 0 {
                        message.name.clone()
                    } else {
                        format!("`{}`", path[..depth].join("."))
                    },
                    key,
                    fields
                        .iter()
                        .map(|(n, _)| n.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            }
        };
    }
    Ok((path, ty))
}

/// Where in a message an entry's value comes from (or a signal's goes):
/// `field` as given, or, when it is not, the whole message, or its only
/// field when `ty` fits that and not the whole.
pub fn place(
    message: &Message,
    field: Option<&str>,
    ty: &PayloadType,
) -> Result<FieldPath, Mismatch> {
    if let Some(text) = field {
        let (path, there) = field_path(message, text).map_err(Mismatch::Field)?;
        return fits(ty, &there, &path).map(|()| path);
    }
    let whole = message.payload_type();
    match fits(ty, &whole, &[]) {
        Ok(()) => Ok(Vec::new()),
        Err(e) => match &whole {
            PayloadType::Record(fields) if fields.len() == 1 => {
                let path = vec![fields[0].0.clone()];
                // Not a record: what the only field has is what matters.
                let record = matches!(ty, PayloadType::Record(_));
                fits(ty, &fields[0].1, &path)
                    .map(|()| path)
                    .map_err(|inner| if record { e } else { inner })
            }
            _ => Err(e),
        },
    }
}

/// Why a type does not fit a message.
#[derive(Debug)]
pub enum Mismatch {
    /// `field` names no field.
    Field(String),
    /// At `path` in the message, the message has `message`, the entry or
    /// signal `ours`.
    Types {
        path: FieldPath,
        message: PayloadType,
        ours: PayloadType,
    },
}

/// Whether a value of type `ours` can stand for (or fill) a value of type
/// `theirs` found at `path`: the same type, or a record of some of its
/// fields, each fitting in turn.
pub fn fits(ours: &PayloadType, theirs: &PayloadType, path: &[String]) -> Result<(), Mismatch> {
    let mismatch = || Mismatch::Types {
        path: path.to_vec(),
        message: theirs.clone(),
        ours: ours.clone(),
    };
    match (ours, theirs) {
        (a, b) if a == b => Ok(()),
        (PayloadType::List(a), PayloadType::List(b)) => fits(a, b, path),
        (PayloadType::Record(want), PayloadType::Record(have)) => {
            for (name, ty) in want {
                let mut inner = path.to_vec();
                inner.push(name.clone());
                match have.iter().find(|(n, _)| n == name) {
                    Some((_, there)) => fits(ty, there, &inner)?,
                    None => {
                        return Err(Mismatch::Field(format!(
                            "field `{}` is not in the message (at `{}` it has: {})",
                            inner.join("."),
                            if path.is_empty() {
                                "the top".to_string()
                            } else {
                                path.join(".")
                            },
                            have.iter()
                                .map(|(n, _)| n.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        )))
                    }
                }
            }
            Ok(())
        }
        _ => Err(mismatch()),
    }
}

impl Mismatch {
    /// One line: which field, the message's type (ROS and WIT) and ours.
    pub fn describe(&self, message: &Message, ours_are: &str) -> String {
        match self {
            Mismatch::Field(text) => text.clone(),
            Mismatch::Types {
                path,
                message: theirs,
                ours,
            } => {
                let ros = ros_type_at(message, path)
                    .map(|t| format!("{t}, "))
                    .unwrap_or_default();
                let at = if path.is_empty() {
                    "the message".to_string()
                } else {
                    format!("field `{}`", path.join("."))
                };
                format!("{at} is {ros}{theirs} in WIT, but {ours_are} {ours}")
            }
        }
    }
}

/// The `.msg` type of the field at `path` (`float32`, `float64[9]`, ...).
fn ros_type_at(message: &Message, path: &[String]) -> Option<String> {
    let mut def = message.def();
    let mut shown = None;
    for key in path {
        let field = def.fields.iter().find(|f| wit_name(&f.name) == *key)?;
        shown = Some(field.to_string());
        if let Base::Nested(name) = &field.base {
            def = message.defs.get(name)?;
        }
    }
    shown
}

/// The part of a message's value that an entry of type `ty` at `path`
/// keeps.
pub fn take(value: &Json, path: &[String], ty: &PayloadType) -> Json {
    let mut at = value;
    for key in path {
        at = at.get(key).unwrap_or(&Json::Null);
    }
    project(at, ty)
}

fn project(value: &Json, ty: &PayloadType) -> Json {
    match (ty, value) {
        (PayloadType::Record(fields), Json::Object(object)) => Json::Object(
            fields
                .iter()
                .map(|(name, t)| {
                    let v = object.get(name).unwrap_or(&Json::Null);
                    (name.clone(), project(v, t))
                })
                .collect::<Map<_, _>>(),
        ),
        (PayloadType::List(t), Json::Array(items)) => {
            Json::Array(items.iter().map(|i| project(i, t)).collect())
        }
        _ => value.clone(),
    }
}

/// A message's value: `base` (the route's fixed values) with `payload`
/// put at `path`, its fields over those of `base`.
pub fn fill(base: &Json, path: &[String], payload: Json) -> Json {
    let mut value = base.clone();
    let mut at = &mut value;
    for key in path {
        if !at.is_object() {
            *at = Json::Object(Map::new());
        }
        at = at
            .as_object_mut()
            .map(|o| o.entry(key.clone()).or_insert(Json::Null))
            .expect("made an object just above");
    }
    merge(at, payload);
    value
}

fn merge(into: &mut Json, from: Json) {
    match (into, from) {
        (Json::Object(a), Json::Object(b)) => {
            for (k, v) in b {
                merge(a.entry(k).or_insert(Json::Null), v);
            }
        }
        (slot, v) => *slot = v,
    }
}

/// A route's `values` table with WIT field names, every name checked
/// against the message.
pub fn values(message: &Message, table: &Json) -> Result<Json, String> {
    fn walk(ty: &PayloadType, value: &Json, path: &str) -> Result<Json, String> {
        match (ty, value) {
            (PayloadType::Record(fields), Json::Object(object)) => {
                let mut out = Map::new();
                for (key, v) in object {
                    let name = wit_name(key);
                    let inner = if path.is_empty() {
                        name.clone()
                    } else {
                        format!("{path}.{name}")
                    };
                    let Some((_, t)) = fields.iter().find(|(n, _)| *n == name) else {
                        return Err(format!(
                            "`values` names field `{inner}`, which the message does not have"
                        ));
                    };
                    out.insert(name, walk(t, v, &inner)?);
                }
                Ok(Json::Object(out))
            }
            (PayloadType::Record(_), other) => {
                Err(format!("`values`: `{path}` is a record, not {other}"))
            }
            _ => Ok(value.clone()),
        }
    }
    walk(&message.payload_type(), table, "")
}

#[cfg(test)]
mod tests {
    use super::super::types::MessageTypes;
    use super::*;
    use serde_json::json;

    fn load(name: &str) -> Message {
        MessageTypes::default().load(name).expect("works")
    }

    fn record(fields: &[(&str, PayloadType)]) -> PayloadType {
        PayloadType::Record(
            fields
                .iter()
                .map(|(n, t)| (n.to_string(), t.clone()))
                .collect(),
        )
    }

    #[test]
    fn an_entry_takes_a_field_some_fields_or_the_only_field() {
        let battery = load("sensor_msgs/msg/BatteryState");
        assert_eq!(
            place(&battery, Some("percentage"), &PayloadType::F32).expect("works"),
            ["percentage"]
        );
        let some = record(&[
            ("percentage", PayloadType::F32),
            ("present", PayloadType::Bool),
        ]);
        assert!(place(&battery, None, &some).expect("works").is_empty());
        let stamp = record(&[("sec", PayloadType::S32)]);
        assert_eq!(
            place(&battery, Some("header.stamp"), &stamp).expect("works"),
            ["header", "stamp"]
        );
        let float = load("std_msgs/msg/Float32");
        assert_eq!(
            place(&float, None, &PayloadType::F32).expect("works"),
            ["data"]
        );

        let value = json!({"header": {"stamp": {"sec": 1, "nanosec": 2}, "frame-id": "b"},
                           "percentage": 0.5, "present": true, "voltage": 12.0});
        assert_eq!(
            take(&value, &[], &some),
            json!({"percentage": 0.5, "present": true})
        );
        assert_eq!(
            take(&value, &["header".into(), "stamp".into()], &stamp),
            json!({"sec": 1})
        );
    }

    #[test]
    fn a_mismatch_names_the_field_and_both_types() {
        let range = load("sensor_msgs/msg/Range");
        let e = place(&range, Some("range"), &PayloadType::F64).expect_err("is refused");
        assert_eq!(
            e.describe(&range, "entry `range` is"),
            "field `range` is float32, f32 in WIT, but entry `range` is f64"
        );
        let e =
            place(&range, None, &record(&[("rang", PayloadType::F32)])).expect_err("is refused");
        assert!(e
            .describe(&range, "x")
            .contains("field `rang` is not in the message"));
        let e = place(&range, Some("header.nope"), &PayloadType::F32).expect_err("is refused");
        assert!(e.describe(&range, "x").contains("has no field `nope`"));
    }

    #[test]
    fn a_signal_fills_a_message_over_fixed_values() {
        let twist = load("geometry_msgs/msg/Twist");
        let base = values(&twist, &json!({"angular": {"z": 0.8}})).expect("works");
        let filled = fill(&base, &["linear".into()], json!({"x": 0.2}));
        assert_eq!(filled, json!({"angular": {"z": 0.8}, "linear": {"x": 0.2}}));
        let e = values(&twist, &json!({"angular": {"w": 1}})).expect_err("is refused");
        assert!(e.contains("angular.w"), "{e}");
    }
}
