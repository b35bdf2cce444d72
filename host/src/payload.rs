//! Typed payloads: values that travel along connections, and their WIT types.
//!
//! Payload types are declared by each plugin's own world, so the host knows
//! them only at run time, from the components' type information. Values move
//! between plugins as [`wasmtime::component::Val`], structurally, without a
//! serialization format of our own; JSON is used only at the edges (trace,
//! CLI, `inject`).
//!
//! wasmtime's `Type` compares equal only within one component, so this
//! module keeps an owned, structural copy ([`PayloadType`]) that can be
//! compared across components and printed in WIT syntax for error messages.

use std::fmt;

use serde_json::{json, Map, Number, Value as Json};
use wasmtime::component::{types, Val};

/// The WIT type of a payload, comparable across components.
#[derive(Clone, Debug, PartialEq, Eq)]
#[allow(missing_docs)]
pub enum PayloadType {
    Bool,
    S8,
    U8,
    S16,
    U16,
    S32,
    U32,
    S64,
    U64,
    F32,
    F64,
    Char,
    String,
    List(Box<PayloadType>),
    Record(Vec<(String, PayloadType)>),
    Tuple(Vec<PayloadType>),
    Variant(Vec<(String, Option<PayloadType>)>),
    Enum(Vec<String>),
    Option(Box<PayloadType>),
    Result {
        ok: Option<Box<PayloadType>>,
        err: Option<Box<PayloadType>>,
    },
    Flags(Vec<String>),
    /// Resources, streams and futures cannot travel between plugins.
    Unsupported(String),
}

impl PayloadType {
    /// Copies a component's type into the structural form.
    pub fn from_wasm(ty: &types::Type) -> Self {
        use types::Type as T;
        let boxed = |t: &types::Type| Box::new(Self::from_wasm(t));
        match ty {
            T::Bool => Self::Bool,
            T::S8 => Self::S8,
            T::U8 => Self::U8,
            T::S16 => Self::S16,
            T::U16 => Self::U16,
            T::S32 => Self::S32,
            T::U32 => Self::U32,
            T::S64 => Self::S64,
            T::U64 => Self::U64,
            T::Float32 => Self::F32,
            T::Float64 => Self::F64,
            T::Char => Self::Char,
            T::String => Self::String,
            T::List(l) => Self::List(boxed(&l.ty())),
            T::Record(r) => Self::Record(
                r.fields()
                    .map(|f| (f.name.to_string(), Self::from_wasm(&f.ty)))
                    .collect(),
            ),
            T::Tuple(t) => Self::Tuple(t.types().map(|t| Self::from_wasm(&t)).collect()),
            T::Variant(v) => Self::Variant(
                v.cases()
                    .map(|c| (c.name.to_string(), c.ty.as_ref().map(Self::from_wasm)))
                    .collect(),
            ),
            T::Enum(e) => Self::Enum(e.names().map(str::to_string).collect()),
            T::Option(o) => Self::Option(boxed(&o.ty())),
            T::Result(r) => Self::Result {
                ok: r.ok().as_ref().map(boxed),
                err: r.err().as_ref().map(boxed),
            },
            T::Flags(f) => Self::Flags(f.names().map(str::to_string).collect()),
            T::Own(_) => Self::Unsupported("resource".into()),
            T::Borrow(_) => Self::Unsupported("borrowed resource".into()),
            T::Future(_) => Self::Unsupported("future".into()),
            T::Stream(_) => Self::Unsupported("stream".into()),
            T::ErrorContext => Self::Unsupported("error-context".into()),
            _ => Self::Unsupported("a type Radar does not know".into()),
        }
    }

    /// The first part of the type that cannot travel between plugins (a
    /// resource, a stream, a future), if there is one.
    pub fn unsupported(&self) -> Option<&str> {
        match self {
            Self::Unsupported(what) => Some(what),
            Self::List(t) | Self::Option(t) => t.unsupported(),
            Self::Record(fields) => fields.iter().find_map(|(_, t)| t.unsupported()),
            Self::Tuple(items) => items.iter().find_map(Self::unsupported),
            Self::Variant(cases) => cases
                .iter()
                .find_map(|(_, t)| t.as_ref().and_then(Self::unsupported)),
            Self::Result { ok, err } => ok
                .as_deref()
                .and_then(Self::unsupported)
                .or_else(|| err.as_deref().and_then(Self::unsupported)),
            _ => None,
        }
    }
}

fn write_list(f: &mut fmt::Formatter<'_>, items: &[PayloadType]) -> fmt::Result {
    for (i, t) in items.iter().enumerate() {
        if i > 0 {
            f.write_str(", ")?;
        }
        write!(f, "{t}")?;
    }
    Ok(())
}

impl fmt::Display for PayloadType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Bool => f.write_str("bool"),
            Self::S8 => f.write_str("s8"),
            Self::U8 => f.write_str("u8"),
            Self::S16 => f.write_str("s16"),
            Self::U16 => f.write_str("u16"),
            Self::S32 => f.write_str("s32"),
            Self::U32 => f.write_str("u32"),
            Self::S64 => f.write_str("s64"),
            Self::U64 => f.write_str("u64"),
            Self::F32 => f.write_str("f32"),
            Self::F64 => f.write_str("f64"),
            Self::Char => f.write_str("char"),
            Self::String => f.write_str("string"),
            Self::List(t) => write!(f, "list<{t}>"),
            Self::Record(fields) => {
                f.write_str("record { ")?;
                for (i, (name, t)) in fields.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    write!(f, "{name}: {t}")?;
                }
                f.write_str(" }")
            }
            Self::Tuple(items) => {
                f.write_str("tuple<")?;
                write_list(f, items)?;
                f.write_str(">")
            }
            Self::Variant(cases) => {
                f.write_str("variant { ")?;
                for (i, (name, t)) in cases.iter().enumerate() {
                    if i > 0 {
                        f.write_str(", ")?;
                    }
                    match t {
                        Some(t) => write!(f, "{name}({t})")?,
                        None => f.write_str(name)?,
                    }
                }
                f.write_str(" }")
            }
            Self::Enum(names) => write!(f, "enum {{ {} }}", names.join(", ")),
            Self::Option(t) => write!(f, "option<{t}>"),
            Self::Result { ok, err } => match (ok, err) {
                (None, None) => f.write_str("result"),
                (Some(ok), None) => write!(f, "result<{ok}>"),
                (None, Some(err)) => write!(f, "result<_, {err}>"),
                (Some(ok), Some(err)) => write!(f, "result<{ok}, {err}>"),
            },
            Self::Flags(names) => write!(f, "flags {{ {} }}", names.join(", ")),
            Self::Unsupported(what) => f.write_str(what),
        }
    }
}

/// A value carried by a signal: what an event's check returned, what a
/// response's start slot was given, and so on. Signals without a payload
/// (an event whose `check` returns `bool`, `exited` of a start slot that
/// returns nothing) carry an empty payload, rendered as JSON `null`.
///
/// One emission's value is shared by every connection it reaches (cloning
/// a payload clones a reference, not the value).
#[derive(Clone, PartialEq)]
pub struct Payload(pub(crate) Shared);

/// A signal's value, shared by its deliveries.
pub(crate) type Shared = Option<std::sync::Arc<Val>>;

impl fmt::Debug for Payload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Payload({})", self.to_json())
    }
}

impl Payload {
    /// The value as wasmtime sees it, if the signal carries one.
    pub fn value(&self) -> Option<&Val> {
        self.0.as_deref()
    }

    /// The value rendered as JSON (the form used by the trace and the CLI).
    pub fn to_json(&self) -> Json {
        self.0.as_deref().map(val_to_json).unwrap_or(Json::Null)
    }

    /// The value as an unsigned integer, if it is one.
    pub fn as_u64(&self) -> Option<u64> {
        self.to_json().as_u64()
    }
}

impl fmt::Display for Payload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.to_json())
    }
}

/// Renders a component value as JSON: records as objects, variants as
/// `{"case": payload}` (or `"case"` without payload), results as
/// `{"ok": v}` / `{"err": v}`, options as the value or `null`.
pub fn val_to_json(val: &Val) -> Json {
    let num = |n: Option<Number>| n.map(Json::Number).unwrap_or(Json::Null);
    match val {
        Val::Bool(b) => json!(b),
        Val::S8(n) => json!(n),
        Val::U8(n) => json!(n),
        Val::S16(n) => json!(n),
        Val::U16(n) => json!(n),
        Val::S32(n) => json!(n),
        Val::U32(n) => json!(n),
        Val::S64(n) => json!(n),
        Val::U64(n) => json!(n),
        // The shortest decimal that reads back as the same f32 (0.4, not
        // 0.4000000059604645).
        Val::Float32(x) if x.is_finite() => num(Number::from_f64(
            x.to_string().parse::<f64>().unwrap_or(f64::from(*x)),
        )),
        Val::Float32(x) => non_finite(f64::from(*x)),
        Val::Float64(x) if x.is_finite() => num(Number::from_f64(*x)),
        Val::Float64(x) => non_finite(*x),
        Val::Char(c) => json!(c.to_string()),
        Val::String(s) => json!(s),
        Val::List(items) | Val::Tuple(items) | Val::FixedLengthList(items) => {
            Json::Array(items.iter().map(val_to_json).collect())
        }
        Val::Map(pairs) => Json::Array(
            pairs
                .iter()
                .map(|(k, v)| json!([val_to_json(k), val_to_json(v)]))
                .collect(),
        ),
        Val::Record(fields) => Json::Object(
            fields
                .iter()
                .map(|(k, v)| (k.clone(), val_to_json(v)))
                .collect::<Map<_, _>>(),
        ),
        Val::Variant(case, None) | Val::Enum(case) => json!(case),
        Val::Variant(case, Some(v)) => json!({ case.clone(): val_to_json(v) }),
        Val::Option(None) => Json::Null,
        Val::Option(Some(v)) => val_to_json(v),
        Val::Result(r) => {
            let (key, v) = match r {
                Ok(v) => ("ok", v),
                Err(v) => ("err", v),
            };
            json!({ key: v.as_deref().map(val_to_json).unwrap_or(Json::Null) })
        }
        Val::Flags(names) => json!(names),
        Val::Resource(_) | Val::Future(_) | Val::Stream(_) | Val::ErrorContext(_) => {
            json!("<unsupported>")
        }
    }
}

/// JSON has no NaN or infinities: they are written as the strings `"NaN"`,
/// `"Infinity"` and `"-Infinity"` (as JavaScript's `Number()` reads them),
/// and read back as such for `f32` and `f64`.
pub(crate) fn non_finite(x: f64) -> Json {
    Json::String(
        if x.is_nan() {
            "NaN"
        } else if x > 0.0 {
            "Infinity"
        } else {
            "-Infinity"
        }
        .into(),
    )
}

/// A float from JSON: a number, or one of [`non_finite`]'s strings.
pub(crate) fn float(json: &Json) -> Option<f64> {
    match json {
        Json::String(s) => match s.as_str() {
            "NaN" => Some(f64::NAN),
            "Infinity" => Some(f64::INFINITY),
            "-Infinity" => Some(f64::NEG_INFINITY),
            _ => None,
        },
        other => other.as_f64(),
    }
}

/// The bytes `val` takes, counted as in a plugin's memory (the canonical
/// ABI's sizes; strings and lists by their contents, so that 256 KiB of
/// bytes is 262,144), or `Err` with the count so far as soon as it passes
/// `limit`: a payload too large is refused without being walked to its end.
pub(crate) fn check_size(val: &Val, limit: usize) -> Result<usize, usize> {
    fn walk(val: &Val, total: &mut usize, limit: usize) -> Result<(), ()> {
        *total += match val {
            Val::Bool(_) | Val::S8(_) | Val::U8(_) => 1,
            Val::S16(_) | Val::U16(_) => 2,
            Val::S32(_) | Val::U32(_) | Val::Float32(_) | Val::Char(_) | Val::Enum(_) => 4,
            Val::S64(_) | Val::U64(_) | Val::Float64(_) => 8,
            Val::String(s) => s.len(),
            Val::Flags(names) => 4 + names.len(),
            Val::List(items) | Val::FixedLengthList(items) => {
                for item in items {
                    walk(item, total, limit)?;
                }
                0
            }
            Val::Tuple(items) => {
                for item in items {
                    walk(item, total, limit)?;
                }
                0
            }
            Val::Record(fields) => {
                for (_, v) in fields {
                    walk(v, total, limit)?;
                }
                0
            }
            Val::Map(pairs) => {
                for (k, v) in pairs {
                    walk(k, total, limit)?;
                    walk(v, total, limit)?;
                }
                0
            }
            Val::Variant(_, v) | Val::Option(v) => {
                if let Some(v) = v {
                    walk(v, total, limit)?;
                }
                4
            }
            Val::Result(r) => {
                if let Some(v) = r.as_ref().unwrap_or_else(|e| e) {
                    walk(v, total, limit)?;
                }
                4
            }
            Val::Resource(_) | Val::Future(_) | Val::Stream(_) | Val::ErrorContext(_) => 4,
        };
        if *total > limit {
            Err(())
        } else {
            Ok(())
        }
    }
    let mut total = 0;
    match walk(val, &mut total, limit) {
        Ok(()) => Ok(total),
        Err(()) => Err(total),
    }
}

/// The most bytes of a payload a trace record shows: a larger one is
/// recorded as `{"$cut": {"bytes": N}}`, N its size (as `check_size`
/// counts it), so that a trace (in memory, in a file, on a terminal) stays
/// small and quick to write however large the payloads that flow.
pub const TRACE_PAYLOAD_BYTES: usize = 16 << 10;

/// A value as a trace record shows it: [`val_to_json`], or for a payload
/// over [`TRACE_PAYLOAD_BYTES`] a note of its size.
pub(crate) fn trace_json(val: &Val) -> Json {
    match check_size(val, usize::MAX) {
        Ok(size) if size <= TRACE_PAYLOAD_BYTES => val_to_json(val),
        Ok(size) | Err(size) => json!({ "$cut": { "bytes": size } }),
    }
}

/// Why a JSON value is not a value of a payload type.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PayloadError {
    /// The JSON has another shape than the type (a string for a `u32`, a
    /// case the variant does not have, ...).
    #[error("expected {expected}, found {found}")]
    Mismatch {
        /// The type, in WIT syntax.
        expected: String,
        /// The JSON that was given.
        found: String,
    },
    /// A whole number the integer type cannot hold.
    #[error("{value} is out of range for {ty}")]
    OutOfRange {
        /// The number given, as JSON.
        value: String,
        /// The integer type, in WIT syntax.
        ty: String,
    },
    /// A type a payload cannot have (a resource, ...).
    #[error("cannot build a value of type {0}")]
    Unsupported(String),
    /// A record without one of its fields.
    #[error("missing field `{field}` of {ty}")]
    MissingField {
        /// The field's name.
        field: String,
        /// The record type, in WIT syntax.
        ty: String,
    },
}

/// Parses JSON into a value of type `ty`: the inverse of [`val_to_json`].
pub fn json_to_val(json: &Json, ty: &PayloadType) -> Result<Val, PayloadError> {
    use PayloadType as P;
    let mismatch = || PayloadError::Mismatch {
        expected: ty.to_string(),
        found: json.to_string(),
    };
    let int = |lo: i128, hi: i128| -> Result<i128, PayloadError> {
        let n = json
            .as_i64()
            .map(i128::from)
            .or_else(|| json.as_u64().map(i128::from))
            .ok_or_else(mismatch)?;
        if n < lo || n > hi {
            return Err(PayloadError::OutOfRange {
                value: n.to_string(),
                ty: ty.to_string(),
            });
        }
        Ok(n)
    };
    // Range-checked just above, so the narrowing casts below cannot wrap.
    Ok(match ty {
        P::Bool => Val::Bool(json.as_bool().ok_or_else(mismatch)?),
        P::S8 => Val::S8(int(i8::MIN.into(), i8::MAX.into())? as i8),
        P::U8 => Val::U8(int(0, u8::MAX.into())? as u8),
        P::S16 => Val::S16(int(i16::MIN.into(), i16::MAX.into())? as i16),
        P::U16 => Val::U16(int(0, u16::MAX.into())? as u16),
        P::S32 => Val::S32(int(i32::MIN.into(), i32::MAX.into())? as i32),
        P::U32 => Val::U32(int(0, u32::MAX.into())? as u32),
        P::S64 => Val::S64(int(i64::MIN.into(), i64::MAX.into())? as i64),
        P::U64 => Val::U64(int(0, u64::MAX.into())? as u64),
        P::F32 => Val::Float32(float(json).ok_or_else(mismatch)? as f32),
        P::F64 => Val::Float64(float(json).ok_or_else(mismatch)?),
        P::Char => {
            let s = json.as_str().ok_or_else(mismatch)?;
            let mut chars = s.chars();
            match (chars.next(), chars.next()) {
                (Some(c), None) => Val::Char(c),
                _ => return Err(mismatch()),
            }
        }
        P::String => Val::String(json.as_str().ok_or_else(mismatch)?.to_string()),
        P::List(t) => Val::List(
            json.as_array()
                .ok_or_else(mismatch)?
                .iter()
                .map(|j| json_to_val(j, t))
                .collect::<Result<_, _>>()?,
        ),
        P::Tuple(ts) => {
            let items = json.as_array().ok_or_else(mismatch)?;
            if items.len() != ts.len() {
                return Err(mismatch());
            }
            Val::Tuple(
                items
                    .iter()
                    .zip(ts)
                    .map(|(j, t)| json_to_val(j, t))
                    .collect::<Result<_, _>>()?,
            )
        }
        P::Record(fields) => {
            let obj = json.as_object().ok_or_else(mismatch)?;
            Val::Record(
                fields
                    .iter()
                    .map(|(name, t)| {
                        let j = obj.get(name).ok_or_else(|| PayloadError::MissingField {
                            field: name.clone(),
                            ty: ty.to_string(),
                        })?;
                        Ok((name.clone(), json_to_val(j, t)?))
                    })
                    .collect::<Result<_, PayloadError>>()?,
            )
        }
        P::Enum(names) => {
            let s = json.as_str().ok_or_else(mismatch)?;
            if !names.iter().any(|n| n == s) {
                return Err(mismatch());
            }
            Val::Enum(s.to_string())
        }
        P::Variant(cases) => {
            let (name, payload) = match json {
                Json::String(s) => (s.as_str(), None),
                Json::Object(o) if o.len() == 1 => {
                    let (k, v) = o.iter().next().ok_or_else(mismatch)?;
                    (k.as_str(), Some(v))
                }
                _ => return Err(mismatch()),
            };
            let (_, case_ty) = cases.iter().find(|(n, _)| n == name).ok_or_else(mismatch)?;
            let inner = match (case_ty, payload) {
                (Some(t), Some(j)) => Some(Box::new(json_to_val(j, t)?)),
                (None, None) => None,
                _ => return Err(mismatch()),
            };
            Val::Variant(name.to_string(), inner)
        }
        P::Option(t) => match json {
            Json::Null => Val::Option(None),
            j => Val::Option(Some(Box::new(json_to_val(j, t)?))),
        },
        P::Result { ok, err } => {
            let obj = json
                .as_object()
                .filter(|o| o.len() == 1)
                .ok_or_else(mismatch)?;
            let side = |t: &Option<Box<PayloadType>>, j: &Json| -> Result<_, PayloadError> {
                match t {
                    Some(t) => Ok(Some(Box::new(json_to_val(j, t)?))),
                    None => Ok(None),
                }
            };
            if let Some(j) = obj.get("ok") {
                Val::Result(Ok(side(ok, j)?))
            } else if let Some(j) = obj.get("err") {
                Val::Result(Err(side(err, j)?))
            } else {
                return Err(mismatch());
            }
        }
        P::Flags(names) => {
            let set = json.as_array().ok_or_else(mismatch)?;
            let mut out = Vec::new();
            for j in set {
                let s = j.as_str().ok_or_else(mismatch)?;
                if !names.iter().any(|n| n == s) {
                    return Err(mismatch());
                }
                out.push(s.to_string());
            }
            Val::Flags(out)
        }
        P::Unsupported(what) => return Err(PayloadError::Unsupported(what.clone())),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_round_trips_through_a_record_type() {
        let ty = PayloadType::Record(vec![
            ("count".into(), PayloadType::U32),
            (
                "label".into(),
                PayloadType::Option(Box::new(PayloadType::String)),
            ),
            (
                "state".into(),
                PayloadType::Variant(vec![
                    ("idle".into(), None),
                    ("at".into(), Some(PayloadType::F64)),
                ]),
            ),
        ]);
        let input = json!({"count": 3, "label": "x", "state": {"at": 1.5}});
        let val = json_to_val(&input, &ty).expect("parses");
        assert_eq!(val_to_json(&val), input);
    }

    #[test]
    fn an_f32_renders_as_its_shortest_decimal() {
        let val = json_to_val(&json!(0.4), &PayloadType::F32).expect("parses");
        assert_eq!(val_to_json(&val), json!(0.4));
    }

    #[test]
    fn json_of_the_wrong_shape_is_refused_with_the_type() {
        let err = json_to_val(&json!("five"), &PayloadType::U32).expect_err("refused");
        assert!(err.to_string().contains("expected u32"), "{err}");
        assert!(matches!(err, PayloadError::Mismatch { .. }), "{err:?}");
        let err = json_to_val(&json!(300), &PayloadType::U8).expect_err("refused");
        assert_eq!(err.to_string(), "300 is out of range for u8");
        assert!(matches!(err, PayloadError::OutOfRange { .. }), "{err:?}");
    }

    #[test]
    fn nan_and_infinities_survive_json() {
        for (x, text) in [
            (f64::NAN, "NaN"),
            (f64::INFINITY, "Infinity"),
            (f64::NEG_INFINITY, "-Infinity"),
        ] {
            let json = val_to_json(&Val::Float64(x));
            assert_eq!(json, json!(text));
            let back = json_to_val(&json, &PayloadType::F64).expect("parses");
            assert!(
                matches!(back, Val::Float64(y) if y.to_bits() == x.to_bits() || (x.is_nan() && y.is_nan()))
            );
            let json32 = val_to_json(&Val::Float32(x as f32));
            assert_eq!(json32, json!(text));
            assert!(json_to_val(&json32, &PayloadType::F32).is_ok());
        }
        assert!(json_to_val(&json!("nan"), &PayloadType::F64).is_err());
    }

    #[test]
    fn a_payloads_size_is_counted_as_in_memory_and_stops_past_the_limit() {
        let bytes = Val::List((0..100).map(Val::U8).collect());
        assert_eq!(check_size(&bytes, 1_000), Ok(100));
        assert_eq!(check_size(&bytes, 100), Ok(100));
        assert_eq!(check_size(&bytes, 50), Err(51));
        let whole = trace_json(&Val::List(vec![Val::U8(0); TRACE_PAYLOAD_BYTES]));
        assert!(whole.is_array(), "up to the bound a payload is shown whole");
        let cut = trace_json(&Val::List(vec![Val::U8(0); TRACE_PAYLOAD_BYTES + 1]));
        assert_eq!(cut, json!({"$cut": {"bytes": TRACE_PAYLOAD_BYTES + 1}}));
    }

    #[test]
    fn resources_are_named_as_what_cannot_travel() {
        let ty = PayloadType::Option(Box::new(PayloadType::Record(vec![(
            "handle".into(),
            PayloadType::Unsupported("resource".into()),
        )])));
        assert_eq!(ty.unsupported(), Some("resource"));
        assert_eq!(PayloadType::U32.unsupported(), None);
    }

    #[test]
    fn types_print_in_wit_syntax() {
        let ty = PayloadType::Result {
            ok: Some(Box::new(PayloadType::U32)),
            err: Some(Box::new(PayloadType::Enum(vec![
                "interrupt".into(),
                "exit".into(),
            ]))),
        };
        assert_eq!(ty.to_string(), "result<u32, enum { interrupt, exit }>");
    }
}
