//! CDR, the wire form of a ROS 2 message (OMG CDR as Fast-CDR writes it,
//! after a four-byte encapsulation header): values read into the JSON form
//! Radar's payloads have (a record is an object keyed by WIT field names)
//! and written back from it.
//!
//! Reading takes either byte order and checks everything it reads: a
//! length past the end, a bool that is not 0 or 1, text that is not UTF-8
//! are errors, never a panic or a huge allocation. Writing is always
//! little-endian, and fills a field the JSON leaves out with its zero
//! value (0, false, "", an empty sequence, a fixed array of zeros).

use serde_json::{Map, Number, Value as Json};

use super::error::CdrError;
use super::msg::{Base, Field, Primitive, Shape};
use super::types::{wit_name, Message};
use crate::payload;

/// The encapsulation header of little-endian CDR.
const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// Reads a message's CDR bytes into its JSON value.
pub fn decode(message: &Message, bytes: &[u8]) -> Result<Json, CdrError> {
    decode_bytes(message, bytes).map_err(CdrError)
}

fn decode_bytes(message: &Message, bytes: &[u8]) -> Result<Json, String> {
    let little = match bytes {
        [0, 1, _, _, ..] => true,
        [0, 0, _, _, ..] => false,
        [a, b, _, _, ..] => {
            return Err(format!(
                "encapsulation {a:#04x} {b:#04x} is not plain CDR (expected 0x00 0x00 or 0x00 0x01)"
            ))
        }
        _ => {
            return Err(format!(
                "{} bytes, shorter than the CDR header",
                bytes.len()
            ))
        }
    };
    let mut reader = Reader {
        data: &bytes[4..],
        pos: 0,
        little,
    };
    reader.message(message, &message.name)
}

/// Writes a message's JSON value as little-endian CDR.
pub fn encode(message: &Message, value: &Json) -> Result<Vec<u8>, CdrError> {
    encode_value(message, value).map_err(CdrError)
}

fn encode_value(message: &Message, value: &Json) -> Result<Vec<u8>, String> {
    let mut writer = Writer {
        out: CDR_LE.to_vec(),
    };
    writer.message(message, &message.name, value, "")?;
    Ok(writer.out)
}

struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    little: bool,
}

impl Reader<'_> {
    fn message(&mut self, message: &Message, name: &str) -> Result<Json, String> {
        let mut object = Map::new();
        for field in &message.defs[name].fields {
            let value = self
                .field(message, field)
                .map_err(|e| format!("field `{}`: {e}", field.name))?;
            object.insert(wit_name(&field.name), value);
        }
        Ok(Json::Object(object))
    }

    fn field(&mut self, message: &Message, field: &Field) -> Result<Json, String> {
        let count = match field.shape {
            Shape::One => return self.element(message, &field.base),
            Shape::Array(n) => n as usize,
            Shape::Bounded(bound) => {
                let n = self.length()?;
                if n > bound as usize {
                    return Err(format!("{n} elements, more than its bound {bound}"));
                }
                n
            }
            Shape::Sequence => self.length()?,
        };
        // Each element takes a byte at least: a count past the end is
        // refused before anything is allocated for it.
        if count > self.data.len().saturating_sub(self.pos) {
            return Err(format!("{count} elements, past the end of the message"));
        }
        (0..count)
            .map(|_| self.element(message, &field.base))
            .collect::<Result<Vec<_>, _>>()
            .map(Json::Array)
    }

    fn element(&mut self, message: &Message, base: &Base) -> Result<Json, String> {
        match base {
            Base::Primitive(p) => self.primitive(*p),
            Base::String { .. } => self.string().map(Json::String),
            Base::Nested(name) => self.message(message, name),
        }
    }

    fn take(&mut self, size: usize) -> Result<&[u8], String> {
        self.pos += (size - self.pos % size) % size;
        let end = self.pos + size;
        let bytes = self
            .data
            .get(self.pos..end)
            .ok_or_else(|| "the message ends too soon".to_string())?;
        self.pos = end;
        Ok(bytes)
    }

    fn fixed<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut bytes: [u8; N] = self.take(N)?.try_into().map_err(|_| "short read")?;
        if !self.little {
            bytes.reverse();
        }
        Ok(bytes)
    }

    fn length(&mut self) -> Result<usize, String> {
        Ok(u32::from_le_bytes(self.fixed()?) as usize)
    }

    fn primitive(&mut self, p: Primitive) -> Result<Json, String> {
        Ok(match p {
            Primitive::Bool => match self.fixed::<1>()?[0] {
                0 => Json::Bool(false),
                1 => Json::Bool(true),
                other => return Err(format!("a bool of {other}")),
            },
            Primitive::Byte | Primitive::Char | Primitive::U8 => self.fixed::<1>()?[0].into(),
            Primitive::I8 => i8::from_le_bytes(self.fixed()?).into(),
            Primitive::I16 => i16::from_le_bytes(self.fixed()?).into(),
            Primitive::U16 => u16::from_le_bytes(self.fixed()?).into(),
            Primitive::I32 => i32::from_le_bytes(self.fixed()?).into(),
            Primitive::U32 => u32::from_le_bytes(self.fixed()?).into(),
            Primitive::I64 => i64::from_le_bytes(self.fixed()?).into(),
            Primitive::U64 => u64::from_le_bytes(self.fixed()?).into(),
            Primitive::F32 => {
                let x = f32::from_le_bytes(self.fixed()?);
                // The shortest decimal that reads back as the same f32, as
                // payloads render them.
                float(x.to_string().parse::<f64>().unwrap_or(f64::from(x)))
            }
            Primitive::F64 => float(f64::from_le_bytes(self.fixed()?)),
        })
    }

    fn string(&mut self) -> Result<String, String> {
        let len = self.length()?;
        let end = self.pos.saturating_add(len);
        let bytes = self
            .data
            .get(self.pos..end)
            .ok_or_else(|| format!("a string of {len} bytes, past the end of the message"))?;
        self.pos += len;
        // The length counts the terminating NUL.
        let text = bytes.strip_suffix(&[0]).unwrap_or(bytes);
        String::from_utf8(text.to_vec()).map_err(|_| "a string that is not UTF-8".to_string())
    }
}

/// A float as payloads write it: a number, or `"NaN"`, `"Infinity"`,
/// `"-Infinity"`.
fn float(x: f64) -> Json {
    Number::from_f64(x).map_or_else(|| payload::non_finite(x), Json::Number)
}

struct Writer {
    out: Vec<u8>,
}

impl Writer {
    fn align(&mut self, size: usize) {
        let pos = self.out.len() - CDR_LE.len();
        let pad = (size - pos % size) % size;
        self.out.resize(self.out.len() + pad, 0);
    }

    fn put(&mut self, bytes: &[u8]) {
        self.align(bytes.len());
        self.out.extend_from_slice(bytes);
    }

    fn message(
        &mut self,
        message: &Message,
        name: &str,
        value: &Json,
        path: &str,
    ) -> Result<(), String> {
        let object = match value {
            Json::Object(object) => Some(object),
            Json::Null => None,
            other => return Err(format!("{}: expected a record, found {other}", at(path))),
        };
        for field in &message.defs[name].fields {
            let key = wit_name(&field.name);
            let path = join(path, &key);
            let value = object.and_then(|o| o.get(&key)).unwrap_or(&Json::Null);
            self.field(message, field, value, &path)?;
        }
        Ok(())
    }

    fn field(
        &mut self,
        message: &Message,
        field: &Field,
        value: &Json,
        path: &str,
    ) -> Result<(), String> {
        if field.shape == Shape::One {
            return self.element(message, &field.base, value, path);
        }
        let items: &[Json] = match value {
            Json::Array(items) => items,
            Json::Null => &[],
            other => return Err(format!("{}: expected a list, found {other}", at(path))),
        };
        match field.shape {
            Shape::Array(n) => {
                if !items.is_empty() && items.len() != n as usize {
                    return Err(format!(
                        "{}: {} elements, but the array has {n}",
                        at(path),
                        items.len()
                    ));
                }
                for i in 0..n as usize {
                    let item = items.get(i).unwrap_or(&Json::Null);
                    self.element(message, &field.base, item, path)?;
                }
                return Ok(());
            }
            Shape::Bounded(bound) if items.len() > bound as usize => {
                return Err(format!(
                    "{}: {} elements, more than its bound {bound}",
                    at(path),
                    items.len()
                ))
            }
            _ => {}
        }
        let count = u32::try_from(items.len())
            .map_err(|_| format!("{}: too many elements for CDR", at(path)))?;
        self.put(&count.to_le_bytes());
        for item in items {
            self.element(message, &field.base, item, path)?;
        }
        Ok(())
    }

    fn element(
        &mut self,
        message: &Message,
        base: &Base,
        value: &Json,
        path: &str,
    ) -> Result<(), String> {
        match base {
            Base::Primitive(p) => self.primitive(*p, value, path),
            Base::String { bound } => {
                let text = match value {
                    Json::String(s) => s.as_str(),
                    Json::Null => "",
                    other => return Err(format!("{}: expected a string, found {other}", at(path))),
                };
                if *bound > 0 && text.len() > *bound as usize {
                    return Err(format!(
                        "{}: {} bytes, more than its bound {bound}",
                        at(path),
                        text.len()
                    ));
                }
                let len = u32::try_from(text.len() + 1)
                    .map_err(|_| format!("{}: a string too long for CDR", at(path)))?;
                self.put(&len.to_le_bytes());
                self.out.extend_from_slice(text.as_bytes());
                self.out.push(0);
                Ok(())
            }
            Base::Nested(name) => self.message(message, name, value, path),
        }
    }

    fn primitive(&mut self, p: Primitive, value: &Json, path: &str) -> Result<(), String> {
        let wrong = || format!("{}: expected {}, found {value}", at(path), p.name());
        let int = |lo: i128, hi: i128| -> Result<i128, String> {
            if value.is_null() {
                return Ok(0);
            }
            let n = value
                .as_i64()
                .map(i128::from)
                .or_else(|| value.as_u64().map(i128::from))
                .ok_or_else(wrong)?;
            if n < lo || n > hi {
                return Err(format!(
                    "{}: {n} is out of range for {}",
                    at(path),
                    p.name()
                ));
            }
            Ok(n)
        };
        let real = || -> Result<f64, String> {
            if value.is_null() {
                return Ok(0.0);
            }
            payload::float(value).ok_or_else(wrong)
        };
        // Range-checked just above, so the narrowing casts cannot wrap.
        match p {
            Primitive::Bool => {
                let b = match value {
                    Json::Bool(b) => *b,
                    Json::Null => false,
                    _ => return Err(wrong()),
                };
                self.put(&[u8::from(b)]);
            }
            Primitive::Byte | Primitive::Char | Primitive::U8 => {
                self.put(&[int(0, 255)? as u8]);
            }
            Primitive::I8 => self.put(&(int(-128, 127)? as i8).to_le_bytes()),
            Primitive::I16 => {
                self.put(&(int(i16::MIN.into(), i16::MAX.into())? as i16).to_le_bytes())
            }
            Primitive::U16 => self.put(&(int(0, u16::MAX.into())? as u16).to_le_bytes()),
            Primitive::I32 => {
                self.put(&(int(i32::MIN.into(), i32::MAX.into())? as i32).to_le_bytes())
            }
            Primitive::U32 => self.put(&(int(0, u32::MAX.into())? as u32).to_le_bytes()),
            Primitive::I64 => {
                self.put(&(int(i64::MIN.into(), i64::MAX.into())? as i64).to_le_bytes())
            }
            Primitive::U64 => self.put(&(int(0, u64::MAX.into())? as u64).to_le_bytes()),
            Primitive::F32 => self.put(&(real()? as f32).to_le_bytes()),
            Primitive::F64 => self.put(&real()?.to_le_bytes()),
        }
        Ok(())
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

fn at(path: &str) -> String {
    format!("field `{path}`")
}

#[cfg(test)]
mod tests {
    use super::super::types::MessageTypes;
    use super::*;
    use serde_json::json;

    fn load(name: &str) -> Message {
        MessageTypes::default().load(name).expect("works")
    }

    #[test]
    fn writes_and_reads_back_a_nested_message_with_padding() {
        let range = load("sensor_msgs/msg/Range");
        let value = json!({
            "header": {"stamp": {"sec": 7, "nanosec": 9}, "frame-id": "sonar"},
            "radiation-type": 1, "field-of-view": 0.5, "min-range": 0.25,
            "max-range": 4.0, "range": 0.375, "variance": 0.0
        });
        let bytes = encode(&range, &value).expect("works");
        // header 4; sec 4, nanosec 4; "sonar\0" len 4 + 6; radiation-type 1
        // at 22; padding to 24; six float32 after it.
        assert_eq!(bytes.len(), 4 + 4 + 4 + 4 + 6 + 1 + 1 + 5 * 4);
        assert_eq!(decode(&range, &bytes).expect("works"), value);
    }

    #[test]
    fn fills_left_out_fields_with_zero_values() {
        let twist = load("geometry_msgs/msg/Twist");
        let bytes = encode(&twist, &json!({"angular": {"z": 0.8}})).expect("works");
        let back = decode(&twist, &bytes).expect("works");
        assert_eq!(back["angular"]["z"], json!(0.8));
        assert_eq!(back["linear"], json!({"x": 0.0, "y": 0.0, "z": 0.0}));
    }

    #[test]
    fn malformed_bytes_are_errors_not_panics() {
        let scan = load("sensor_msgs/msg/LaserScan");
        let good = encode(&scan, &json!({"ranges": [1.0, 2.0]})).expect("works");
        for cut in 0..good.len() {
            assert!(decode(&scan, &good[..cut]).is_err(), "cut at {cut}");
        }
        // A sequence claiming four billion elements.
        let mut huge = encode(&load("std_msgs/msg/Float32MultiArray"), &json!({})).expect("works");
        let at = huge.len() - 4;
        huge[at..].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode(&load("std_msgs/msg/Float32MultiArray"), &huge).expect_err("is refused");
        assert!(e.0.contains("past the end"), "{e}");
        let e = decode(&load("std_msgs/msg/Bool"), &[0, 1, 0, 0, 7]).expect_err("is refused");
        assert!(e.0.contains("a bool of 7"), "{e}");
        let e = decode(&load("std_msgs/msg/Bool"), &[0, 7, 0, 0, 1]).expect_err("is refused");
        assert!(e.0.contains("encapsulation"), "{e}");
    }

    #[test]
    fn refuses_values_that_do_not_fit_naming_the_field() {
        let imu = load("sensor_msgs/msg/Imu");
        let e = encode(&imu, &json!({"orientation-covariance": [1.0]})).expect_err("is refused");
        assert!(
            e.0.contains("orientation-covariance") && e.0.contains("has 9"),
            "{e}"
        );
        let e = encode(&load("std_msgs/msg/UInt32"), &json!({"data": -1})).expect_err("is refused");
        assert!(e.0.contains("out of range for uint32"), "{e}");
    }
}
