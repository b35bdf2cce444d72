//! A message type as WIT text that pastes into a plugin's interface as it
//! is (`radar ros2 show TYPE --wit`): one named record per message type it
//! uses, dependencies first, so a plugin can build a whole `Twist` and send
//! it as a named signal that a `[[ros2.publish]]` route puts on a topic.
//! The field names are those of [`Message::payload_type`], so a record
//! pasted from here fits the message exactly.

use std::collections::BTreeMap;
use std::fmt::Write;

use super::msg::{Base, Shape};
use super::types::{primitive_type, wit_name, Message};
use crate::wit_names::{ident, kebab};

impl Message {
    /// The WIT records of this message and of every message it uses,
    /// dependencies first, each with a doc comment naming its ROS type.
    pub fn wit_definitions(&self) -> String {
        let names = self.record_names();
        let mut order = Vec::new();
        self.visit(&self.name, &mut order);
        let mut out = String::new();
        for (i, type_name) in order.iter().enumerate() {
            if i > 0 {
                out.push('\n');
            }
            let _ = writeln!(out, "/// {type_name}");
            let _ = writeln!(out, "record {} {{", ident(&names[type_name]));
            for field in &self.defs[type_name].fields {
                let element = match &field.base {
                    Base::Primitive(p) => primitive_type(*p).to_string(),
                    Base::String { .. } => "string".to_string(),
                    Base::Nested(nested) => ident(&names[nested]),
                };
                let ty = match field.shape {
                    Shape::One => element,
                    _ => format!("list<{element}>"),
                };
                let _ = writeln!(out, "    {}: {ty},", ident(&wit_name(&field.name)));
            }
            out.push_str("}\n");
        }
        out
    }

    /// Every type this message uses, after those it uses in turn.
    fn visit(&self, name: &str, order: &mut Vec<String>) {
        if order.iter().any(|n| n == name) {
            return;
        }
        for field in &self.defs[name].fields {
            if let Base::Nested(nested) = &field.base {
                self.visit(nested, order);
            }
        }
        order.push(name.to_string());
    }

    /// Each type's record name: its own name in kebab case, or, where two
    /// packages have a type of that name, with its package before it.
    fn record_names(&self) -> BTreeMap<String, String> {
        let short = |full: &str| kebab(full.rsplit('/').next().unwrap_or(full));
        let mut count: BTreeMap<String, usize> = BTreeMap::new();
        for full in self.defs.keys() {
            *count.entry(short(full)).or_default() += 1;
        }
        self.defs
            .keys()
            .map(|full| {
                let name = short(full);
                let name = if count[&name] > 1 {
                    let package = full.split('/').next().unwrap_or_default();
                    format!("{}-{name}", kebab(package))
                } else {
                    name
                };
                (full.clone(), name)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::network::ros2::MessageTypes;

    #[test]
    fn a_twist_prints_its_vector3_first() {
        let twist = MessageTypes::default()
            .load("geometry_msgs/msg/Twist")
            .expect("built in");
        assert_eq!(
            twist.wit_definitions(),
            "/// geometry_msgs/msg/Vector3\nrecord vector3 {\n    x: f64,\n    y: f64,\n    \
             z: f64,\n}\n\n/// geometry_msgs/msg/Twist\nrecord twist {\n    linear: vector3,\n    \
             angular: vector3,\n}\n"
        );
    }

    #[test]
    fn keywords_are_escaped() {
        let string = MessageTypes::default()
            .load("std_msgs/msg/String")
            .expect("built in");
        assert!(string
            .wit_definitions()
            .contains("record %string {\n    data: string,\n}"));
    }
}
