//! The RIHS01 type hash (ROS 2's REP 2011) of a message type: the SHA-256
//! of the type's description and of every type it refers to, in the JSON
//! form rosidl hashes. rmw_zenoh puts it in every key expression, so a
//! publisher and a subscriber of different definitions never meet.

use std::collections::BTreeMap;
use std::fmt::Write;

use sha2::{Digest, Sha256};

use super::msg::{Base, Field, MessageDef, Primitive, Shape};

/// `RIHS01_<64 hex digits>` of `name`, whose definition and those of every
/// type it refers to are in `defs`.
pub fn rihs01(name: &str, defs: &BTreeMap<String, MessageDef>) -> String {
    let mut text = String::from("{\"type_description\": ");
    describe(&defs[name], &mut text);
    text.push_str(", \"referenced_type_descriptions\": [");
    let mut first = true;
    // `defs` is sorted by name, as rosidl sorts the referenced types.
    for (other, def) in defs {
        if other != name {
            if !first {
                text.push_str(", ");
            }
            first = false;
            describe(def, &mut text);
        }
    }
    text.push_str("]}");
    let digest = Sha256::digest(text.as_bytes());
    let mut hash = String::from("RIHS01_");
    for byte in digest {
        let _ = write!(hash, "{byte:02x}");
    }
    hash
}

fn describe(def: &MessageDef, out: &mut String) {
    let _ = write!(out, "{{\"type_name\": \"{}\", \"fields\": [", def.name);
    for (i, field) in def.fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let (id, capacity, string_capacity, nested) = field_type(field);
        let _ = write!(
            out,
            "{{\"name\": \"{}\", \"type\": {{\"type_id\": {id}, \"capacity\": {capacity}, \
             \"string_capacity\": {string_capacity}, \"nested_type_name\": \"{nested}\"}}}}",
            field.name
        );
    }
    out.push_str("]}");
}

/// The field's `type_id` (type_description_interfaces/msg/FieldType),
/// `capacity`, `string_capacity` and `nested_type_name`.
fn field_type(field: &Field) -> (u32, u32, u32, &str) {
    let (base_id, string_capacity, nested) = match &field.base {
        Base::Primitive(p) => (primitive_id(*p), 0, ""),
        Base::String { bound: 0 } => (17, 0, ""),
        Base::String { bound } => (21, *bound, ""),
        Base::Nested(name) => (1, 0, name.as_str()),
    };
    let (offset, capacity) = match field.shape {
        Shape::One => (0, 0),
        Shape::Array(n) => (48, n),
        Shape::Bounded(n) => (96, n),
        Shape::Sequence => (144, 0),
    };
    (base_id + offset, capacity, string_capacity, nested)
}

fn primitive_id(p: Primitive) -> u32 {
    match p {
        Primitive::I8 => 2,
        Primitive::U8 => 3,
        Primitive::I16 => 4,
        Primitive::U16 => 5,
        Primitive::I32 => 6,
        Primitive::U32 => 7,
        Primitive::I64 => 8,
        Primitive::U64 => 9,
        Primitive::F32 => 10,
        Primitive::F64 => 11,
        Primitive::Char => 13,
        Primitive::Bool => 15,
        Primitive::Byte => 16,
    }
}
