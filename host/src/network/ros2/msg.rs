//! ROS 2 message definitions: the `.msg` format read into fields.
//!
//! Only what a message carries matters here: each field's name, its base
//! type (a primitive, a string, or another message) and its shape (one
//! value, a fixed array, a bounded or unbounded sequence). Constants and
//! default values are read past; comments are dropped. An empty message
//! gets the one `uint8` member ROS 2 gives it, so that its CDR form and its
//! type hash are ROS 2's.

use std::fmt;

use serde::{Deserialize, Serialize};

/// The largest fixed array or sequence bound a definition may give.
pub const MAX_ARRAY: u32 = 1 << 24;

/// The name ROS 2 gives the member of an otherwise empty message.
pub const EMPTY_MEMBER: &str = "structure_needs_at_least_one_member";

/// A primitive ROS 2 type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Primitive {
    /// `bool`
    Bool,
    /// `byte`
    Byte,
    /// `char`
    Char,
    /// `int8`
    I8,
    /// `uint8`
    U8,
    /// `int16`
    I16,
    /// `uint16`
    U16,
    /// `int32`
    I32,
    /// `uint32`
    U32,
    /// `int64`
    I64,
    /// `uint64`
    U64,
    /// `float32`
    F32,
    /// `float64`
    F64,
}

impl Primitive {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "bool" => Self::Bool,
            "byte" => Self::Byte,
            "char" => Self::Char,
            "int8" => Self::I8,
            "uint8" => Self::U8,
            "int16" => Self::I16,
            "uint16" => Self::U16,
            "int32" => Self::I32,
            "uint32" => Self::U32,
            "int64" => Self::I64,
            "uint64" => Self::U64,
            "float32" => Self::F32,
            "float64" => Self::F64,
            _ => return None,
        })
    }

    /// Its name in a `.msg` file.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bool => "bool",
            Self::Byte => "byte",
            Self::Char => "char",
            Self::I8 => "int8",
            Self::U8 => "uint8",
            Self::I16 => "int16",
            Self::U16 => "uint16",
            Self::I32 => "int32",
            Self::U32 => "uint32",
            Self::I64 => "int64",
            Self::U64 => "uint64",
            Self::F32 => "float32",
            Self::F64 => "float64",
        }
    }
}

/// What one element of a field is.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Base {
    /// A number or a bool.
    Primitive(Primitive),
    /// A UTF-8 string, at most `bound` bytes if `bound` is not 0.
    String {
        /// The most bytes it may hold (0: no bound).
        bound: u32,
    },
    /// Another message, by its full name (`pkg/msg/Name`).
    Nested(String),
}

/// How many elements a field has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Shape {
    /// One value.
    One,
    /// `T[N]`: exactly N.
    Array(u32),
    /// `T[<=N]`: up to N.
    Bounded(u32),
    /// `T[]`: any number.
    Sequence,
}

/// One field of a message.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Field {
    /// Its name, as the `.msg` file writes it (`frame_id`).
    pub name: String,
    /// What each element is.
    pub base: Base,
    /// How many elements it has.
    pub shape: Shape,
}

/// A message type's fields, in order.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct MessageDef {
    /// `pkg/msg/Name`.
    pub name: String,
    /// Its fields, in order (constants left out).
    pub fields: Vec<Field>,
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.base {
            Base::Primitive(p) => write!(f, "{}", p.name())?,
            Base::String { bound: 0 } => write!(f, "string")?,
            Base::String { bound } => write!(f, "string<={bound}")?,
            Base::Nested(name) => write!(f, "{name}")?,
        }
        match self.shape {
            Shape::One => Ok(()),
            Shape::Array(n) => write!(f, "[{n}]"),
            Shape::Bounded(n) => write!(f, "[<={n}]"),
            Shape::Sequence => write!(f, "[]"),
        }
    }
}

/// Reads a `.msg` file's text as the definition of `name` (`pkg/msg/Name`).
/// Errors name the line.
pub fn parse(name: &str, text: &str) -> Result<MessageDef, String> {
    let package = name.split('/').next().unwrap_or_default();
    let mut fields = Vec::new();
    for (number, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or_default().trim();
        if line.is_empty() {
            continue;
        }
        let at = |what: String| format!("{name}, line {}: {what}", number + 1);
        let (ty, rest) = line
            .split_once(char::is_whitespace)
            .ok_or_else(|| at(format!("`{line}` is a type without a field name")))?;
        let rest = rest.trim();
        // A constant (`uint8 NEAR=1`, `string S = "x"`): not carried.
        if rest.contains('=') {
            continue;
        }
        // What follows the name is a default value: not carried either.
        let field = rest.split_whitespace().next().unwrap_or_default();
        if !is_field_name(field) {
            return Err(at(format!(
                "`{field}` is not a field name (lower case letters, digits and `_`)"
            )));
        }
        let (base, shape) = parse_type(ty, package).map_err(at)?;
        fields.push(Field {
            name: field.to_string(),
            base,
            shape,
        });
    }
    if fields.is_empty() {
        fields.push(Field {
            name: EMPTY_MEMBER.to_string(),
            base: Base::Primitive(Primitive::U8),
            shape: Shape::One,
        });
    }
    Ok(MessageDef {
        name: name.to_string(),
        fields,
    })
}

fn is_field_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

/// `float64[9]`, `string<=10`, `geometry_msgs/Point[]`, `Header`, ...
fn parse_type(text: &str, package: &str) -> Result<(Base, Shape), String> {
    let (element, shape) = match text.split_once('[') {
        None => (text, Shape::One),
        Some((element, rest)) => {
            let inner = rest
                .strip_suffix(']')
                .ok_or_else(|| format!("`{text}`: an array type ends with `]`"))?;
            let count = |digits: &str| {
                digits
                    .trim()
                    .parse::<u32>()
                    .map_err(|_| format!("`{text}`: `{digits}` is not a size"))
            };
            let count = |digits: &str| {
                count(digits).and_then(|n| {
                    if n > MAX_ARRAY {
                        Err(format!(
                            "`{text}`: {n} elements, more than Radar takes ({MAX_ARRAY})"
                        ))
                    } else {
                        Ok(n)
                    }
                })
            };
            let shape = if inner.is_empty() {
                Shape::Sequence
            } else if let Some(bound) = inner.strip_prefix("<=") {
                Shape::Bounded(count(bound)?)
            } else {
                Shape::Array(count(inner)?)
            };
            (element, shape)
        }
    };
    let base = if let Some(p) = Primitive::parse(element) {
        Base::Primitive(p)
    } else if element == "string" {
        Base::String { bound: 0 }
    } else if let Some(bound) = element.strip_prefix("string<=") {
        Base::String {
            bound: bound
                .parse()
                .map_err(|_| format!("`{text}`: `{bound}` is not a string bound"))?,
        }
    } else if element == "wstring" || element.starts_with("wstring<=") {
        return Err(format!(
            "`{text}`: wide strings are not supported (use `string`)"
        ));
    } else {
        Base::Nested(full_name(element, package)?)
    };
    Ok((base, shape))
}

/// A nested type's full name: `Header` in package `std_msgs`, `pkg/Name`
/// and `pkg/msg/Name` all become `pkg/msg/Name`.
fn full_name(text: &str, package: &str) -> Result<String, String> {
    let valid = |part: &str| {
        !part.is_empty() && part.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    let parts: Vec<&str> = text.split('/').collect();
    let name = match parts.as_slice() {
        [name] => format!("{package}/msg/{name}"),
        [pkg, name] => format!("{pkg}/msg/{name}"),
        [pkg, "msg", name] => format!("{pkg}/msg/{name}"),
        _ => String::new(),
    };
    if name.is_empty() || !parts.iter().all(|p| valid(p)) {
        return Err(format!("`{text}` is not a type"));
    }
    Ok(name)
}

/// Whether `name` is a message type's full name (`pkg/msg/Name`).
pub fn is_type_name(name: &str) -> bool {
    let parts: Vec<&str> = name.split('/').collect();
    matches!(parts.as_slice(), [pkg, "msg", n] if !pkg.is_empty() && !n.is_empty()
        && pkg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_fields_and_skips_constants_comments_and_defaults() {
        let def = parse(
            "sensor_msgs/msg/Range",
            "uint8 ULTRASOUND=0 # a constant\n\
             std_msgs/msg/Header header\n\
             float32 range  # metres\n\
             float64[9] covariance\n\
             string<=8[<=3] tags\n\
             Point[] points\n\
             int32 count 7\n",
        )
        .expect("works");
        let shown: Vec<String> = def
            .fields
            .iter()
            .map(|f| format!("{f} {}", f.name))
            .collect();
        assert_eq!(
            shown,
            [
                "std_msgs/msg/Header header",
                "float32 range",
                "float64[9] covariance",
                "string<=8[<=3] tags",
                "sensor_msgs/msg/Point[] points",
                "int32 count",
            ]
        );
    }

    #[test]
    fn an_empty_message_has_ros_2s_one_member() {
        let def = parse("std_msgs/msg/Empty", "# nothing\n").expect("works");
        assert_eq!(def.fields.len(), 1);
        assert_eq!(def.fields[0].name, EMPTY_MEMBER);
    }

    #[test]
    fn refuses_what_it_cannot_read_naming_the_line() {
        let e = parse("a/msg/B", "int32 x\nfloat32[x] y\n").expect_err("is refused");
        assert!(
            e.contains("a/msg/B, line 2") && e.contains("not a size"),
            "{e}"
        );
        let e = parse("a/msg/B", "wstring w\n").expect_err("is refused");
        assert!(e.contains("wide strings"), "{e}");
        let e = parse("a/msg/B", "int32 Bad\n").expect_err("is refused");
        assert!(e.contains("not a field name"), "{e}");
    }
}
