//! Messages through RustDDS's serde-based CDR, as the bytes `cdr` reads and
//! writes: the DDS side (`dds`) then shares every check and every value
//! with the rmw_zenoh side.
//!
//! A message Radar publishes is encoded by `cdr::encode` and handed to the
//! DDS writer as a tuple of bytes ([`Encoded`]): CDR writes a tuple's
//! elements with no length, and a byte needs no alignment, so the writer
//! puts out exactly those bytes after its own encapsulation header.
//!
//! A message taken is read by walking its definition ([`Recode`]): each
//! field is asked of the deserializer as what it is (RustDDS knows the
//! sender's byte order) and written back as little-endian CDR, aligned as
//! CDR aligns it, for `cdr::decode` to read and check as it reads anything.

use std::fmt;
use std::sync::Arc;

use serde::de::{self, DeserializeSeed, Deserializer, SeqAccess, Visitor};
use serde::ser::{Serialize, SerializeTuple, Serializer};

use super::error::CdrError;
use super::msg::{Base, Field, Primitive, Shape};
use super::types::Message;

/// Reads a message as a DDS subscription does (`bytes`: CDR after its
/// 4-byte encapsulation header, as a DDS node puts it on the wire), through
/// RustDDS's own deserializer, into the little-endian CDR bytes `cdr`
/// reads. For tests against other libraries' bytes.
pub fn read_as_dds(message: &Message, bytes: &[u8]) -> Result<Vec<u8>, CdrError> {
    use ros2_client::dds::rustdds::serialization::deserialize_from_cdr_with_decoder_and_rep_id;
    use ros2_client::dds::rustdds::RepresentationIdentifier;
    let (header, body) = bytes
        .split_at_checked(CDR_LE.len())
        .ok_or_else(|| CdrError("shorter than the CDR header".into()))?;
    let encoding =
        RepresentationIdentifier::from_bytes(header).map_err(|e| CdrError(e.to_string()))?;
    let seed = Recode {
        message: Arc::new(message.clone()),
    };
    deserialize_from_cdr_with_decoder_and_rep_id(body, encoding, seed)
        .map(|(Recoded(bytes), _)| bytes)
        .map_err(|e| CdrError(e.to_string()))
}

/// The encapsulation header of little-endian CDR (as `cdr` writes it).
const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// A message as `cdr::encode` made it (header included), to publish.
#[derive(Clone)]
pub(super) struct Encoded(pub(super) Vec<u8>);

/// ros2-client's service client wants its request type readable too; Radar
/// never reads its own requests back.
impl<'de> de::Deserialize<'de> for Encoded {
    fn deserialize<D: Deserializer<'de>>(_: D) -> Result<Self, D::Error> {
        Err(de::Error::custom("Radar does not read its own requests"))
    }
}

impl ros2_client::Message for Encoded {}
impl ros2_client::Message for Answered {}

thread_local! {
    /// What [`Answered`] reads, on the thread that takes a service's
    /// replies: ros2-client reads a reply as a plain `Deserialize` type,
    /// which takes no seed of its own.
    static REPLY: std::cell::RefCell<Option<Recode>> = const { std::cell::RefCell::new(None) };
}

/// A service's reply taken from DDS, as [`Recoded`] bytes: read with the
/// [`Recode`] given to [`Answered::read_on_this_thread`].
#[derive(Clone, Debug)]
pub(super) struct Answered(pub(super) Vec<u8>);

impl Answered {
    /// Replies taken on this thread are of `message`.
    pub(super) fn read_on_this_thread(message: Arc<Message>) {
        REPLY.with(|r| *r.borrow_mut() = Some(Recode { message }));
    }
}

impl<'de> de::Deserialize<'de> for Answered {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let seed = REPLY
            .with(|r| r.borrow().clone())
            .ok_or_else(|| de::Error::custom("no reply type on this thread"))?;
        seed.deserialize(deserializer).map(|Recoded(b)| Answered(b))
    }
}

impl Serialize for Answered {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        Encoded(self.0.clone()).serialize(serializer)
    }
}

impl fmt::Debug for Encoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "a message of {} bytes", self.0.len())
    }
}

impl Serialize for Encoded {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let body = self.0.get(CDR_LE.len()..).unwrap_or_default();
        let mut tuple = serializer.serialize_tuple(body.len())?;
        for byte in body {
            tuple.serialize_element(byte)?;
        }
        tuple.end()
    }
}

/// A message taken from DDS, as little-endian CDR bytes (header included).
pub(super) struct Recoded(pub(super) Vec<u8>);

/// Reads one message of a type, field by field (see the module docs).
#[derive(Clone)]
pub(super) struct Recode {
    pub(super) message: Arc<Message>,
}

impl<'de> DeserializeSeed<'de> for Recode {
    type Value = Recoded;

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<Recoded, D::Error> {
        let mut out = Out(CDR_LE.to_vec());
        Struct {
            message: &self.message,
            name: &self.message.name,
            out: &mut out,
        }
        .deserialize(deserializer)?;
        Ok(Recoded(out.0))
    }
}

/// The bytes written so far, header first.
struct Out(Vec<u8>);

impl Out {
    /// Pads to `size` from the end of the header, as CDR aligns.
    fn align(&mut self, size: usize) {
        let pos = self.0.len() - CDR_LE.len();
        let pad = (size - pos % size) % size;
        self.0.resize(self.0.len() + pad, 0);
    }

    fn put(&mut self, bytes: &[u8]) {
        self.align(bytes.len());
        self.0.extend_from_slice(bytes);
    }
}

/// One message (a struct: its fields in order, with nothing between).
struct Struct<'a> {
    message: &'a Message,
    name: &'a str,
    out: &'a mut Out,
}

impl<'de> DeserializeSeed<'de> for Struct<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        let fields = self.message.defs[self.name].fields.len();
        deserializer.deserialize_tuple(fields, self)
    }
}

impl<'de> Visitor<'de> for Struct<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "a {}", self.name)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        for field in &self.message.defs[self.name].fields {
            let seed = FieldSeed {
                message: self.message,
                field,
                out: self.out,
            };
            seq.next_element_seed(seed)
                .map_err(|e| de::Error::custom(format!("field `{}`: {e}", field.name)))?
                .ok_or_else(|| de::Error::custom("the message ends too soon"))?;
        }
        Ok(())
    }
}

/// One field: one element, a fixed array, or a sequence with its length.
struct FieldSeed<'a> {
    message: &'a Message,
    field: &'a Field,
    out: &'a mut Out,
}

impl<'de> DeserializeSeed<'de> for FieldSeed<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        match self.field.shape {
            Shape::One => Element {
                message: self.message,
                base: &self.field.base,
                out: self.out,
            }
            .deserialize(deserializer),
            Shape::Array(n) => deserializer.deserialize_tuple(n as usize, self),
            Shape::Bounded(_) | Shape::Sequence => deserializer.deserialize_seq(self),
        }
    }
}

impl<'de> Visitor<'de> for FieldSeed<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.field)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        // A sequence's count comes first: written once its elements are
        // counted (they are read one by one, never allocated ahead).
        let count_at = match self.field.shape {
            Shape::Array(_) => None,
            _ => {
                self.out.align(4);
                self.out.0.extend_from_slice(&[0; 4]);
                Some(self.out.0.len() - 4)
            }
        };
        let mut count: u32 = 0;
        loop {
            let element = Element {
                message: self.message,
                base: &self.field.base,
                out: self.out,
            };
            match seq.next_element_seed(element)? {
                Some(()) => count += 1,
                None => break,
            }
        }
        if let Some(at) = count_at {
            self.out.0[at..at + 4].copy_from_slice(&count.to_le_bytes());
        }
        Ok(())
    }
}

/// One element: a primitive, a string or a nested message.
struct Element<'a> {
    message: &'a Message,
    base: &'a Base,
    out: &'a mut Out,
}

impl<'de> DeserializeSeed<'de> for Element<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, deserializer: D) -> Result<(), D::Error> {
        match self.base {
            Base::Nested(name) => Struct {
                message: self.message,
                name,
                out: self.out,
            }
            .deserialize(deserializer),
            Base::String { .. } => deserializer.deserialize_string(Text(self.out)),
            Base::Primitive(p) => {
                let visitor = Number(self.out);
                match p {
                    Primitive::Bool => deserializer.deserialize_bool(visitor),
                    Primitive::Byte | Primitive::Char | Primitive::U8 => {
                        deserializer.deserialize_u8(visitor)
                    }
                    Primitive::I8 => deserializer.deserialize_i8(visitor),
                    Primitive::I16 => deserializer.deserialize_i16(visitor),
                    Primitive::U16 => deserializer.deserialize_u16(visitor),
                    Primitive::I32 => deserializer.deserialize_i32(visitor),
                    Primitive::U32 => deserializer.deserialize_u32(visitor),
                    Primitive::I64 => deserializer.deserialize_i64(visitor),
                    Primitive::U64 => deserializer.deserialize_u64(visitor),
                    Primitive::F32 => deserializer.deserialize_f32(visitor),
                    Primitive::F64 => deserializer.deserialize_f64(visitor),
                }
            }
        }
    }
}

/// Writes the primitive it is given, little-endian and aligned.
struct Number<'a>(&'a mut Out);

impl<'de> Visitor<'de> for Number<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a number or a bool")
    }

    fn visit_bool<E: de::Error>(self, v: bool) -> Result<(), E> {
        self.0.put(&[u8::from(v)]);
        Ok(())
    }
    fn visit_u8<E: de::Error>(self, v: u8) -> Result<(), E> {
        self.0.put(&[v]);
        Ok(())
    }
    fn visit_i8<E: de::Error>(self, v: i8) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_i16<E: de::Error>(self, v: i16) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_u16<E: de::Error>(self, v: u16) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_i32<E: de::Error>(self, v: i32) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_u32<E: de::Error>(self, v: u32) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_f32<E: de::Error>(self, v: f32) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<(), E> {
        self.0.put(&v.to_le_bytes());
        Ok(())
    }
}

/// Writes a string as CDR does: its length with the NUL, the bytes, NUL.
struct Text<'a>(&'a mut Out);

impl<'de> Visitor<'de> for Text<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a string")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<(), E> {
        let len = u32::try_from(v.len() + 1).map_err(|_| E::custom("a string too long"))?;
        self.0.put(&len.to_le_bytes());
        self.0 .0.extend_from_slice(v.as_bytes());
        self.0 .0.push(0);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::ros2::{cdr, MessageTypes};
    use byteorder::{BigEndian, ByteOrder, LittleEndian};
    use ros2_client::dds::rustdds::cdr_encoding;
    use serde_json::json;

    /// `sensor_msgs/msg/LaserScan` as a typed ROS 2 library declares it:
    /// what RustDDS writes for it is what any DDS node writes.
    #[derive(serde::Serialize)]
    struct Scan {
        header: (i32, u32, String),
        angles: [f32; 3],
        times: [f32; 2],
        range: [f32; 2],
        ranges: Vec<f32>,
        intensities: Vec<f32>,
    }

    fn scan() -> (Scan, serde_json::Value) {
        let typed = Scan {
            header: (3, 7, "laser".into()),
            angles: [-1.5, 1.5, 0.25],
            times: [0.0, 0.1],
            range: [0.1, 10.0],
            ranges: vec![0.5, 1.25, 3.0],
            intensities: vec![],
        };
        let value = json!({
            "header": {"stamp": {"sec": 3, "nanosec": 7}, "frame-id": "laser"},
            "angle-min": -1.5, "angle-max": 1.5, "angle-increment": 0.25,
            "time-increment": 0.0, "scan-time": 0.1, "range-min": 0.1, "range-max": 10.0,
            "ranges": [0.5, 1.25, 3.0], "intensities": [],
        });
        (typed, value)
    }

    fn laser_scan() -> Arc<Message> {
        Arc::new(
            MessageTypes::new(Vec::new())
                .load("sensor_msgs/msg/LaserScan")
                .expect("a built-in type"),
        )
    }

    /// Reads as RustDDS does, in byte order `BO`.
    fn read<BO: ByteOrder>(wire: &[u8], seed: Recode) -> cdr_encoding::Result<Recoded> {
        seed.deserialize(&mut cdr_encoding::CdrDeserializer::<BO>::new(wire))
    }

    fn taken<BO: ByteOrder>(wire: &[u8], message: &Arc<Message>) -> serde_json::Value {
        let seed = Recode {
            message: message.clone(),
        };
        let Recoded(bytes) = read::<BO>(wire, seed).expect("reads");
        cdr::decode(message, &bytes).expect("decodes")
    }

    #[test]
    fn a_message_published_is_what_a_typed_ros_2_node_writes() {
        let message = laser_scan();
        let (typed, value) = scan();
        let ours = cdr::encode(&message, &value).expect("encodes");
        let through =
            cdr_encoding::to_vec::<_, LittleEndian>(&Encoded(ours.clone())).expect("writes");
        assert_eq!(through, ours[4..], "the bytes pass through unchanged");
        let theirs = cdr_encoding::to_vec::<_, LittleEndian>(&typed).expect("writes");
        assert_eq!(through, theirs, "the same bytes as a typed node's");
    }

    #[test]
    fn a_message_taken_reads_the_same_in_either_byte_order() {
        let message = laser_scan();
        let (typed, value) = scan();
        let little = cdr_encoding::to_vec::<_, LittleEndian>(&typed).expect("writes");
        let big = cdr_encoding::to_vec::<_, BigEndian>(&typed).expect("writes");
        assert_ne!(little, big);
        assert_eq!(taken::<LittleEndian>(&little, &message), value);
        assert_eq!(taken::<BigEndian>(&big, &message), value);
    }

    #[test]
    fn a_short_or_lying_message_is_an_error_not_a_panic_or_an_allocation() {
        let message = laser_scan();
        let (typed, _) = scan();
        let wire = cdr_encoding::to_vec::<_, LittleEndian>(&typed).expect("writes");
        let seed = || Recode {
            message: message.clone(),
        };
        let short = read::<LittleEndian>(&wire[..20], seed());
        assert!(short.is_err());
        // `ranges` claims four billion elements.
        let mut lying = wire.clone();
        let at = wire.len() - 4 - 12 - 4;
        lying[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let error = read::<LittleEndian>(&lying, seed()).err().expect("refused");
        assert!(error.to_string().contains("ranges"), "{error}");
    }
}
