//! The trace: every observable step of a run, in order (`docs/trace.md`).
//!
//! Under the virtual clock a run is a pure function of its inputs, so the
//! trace is the artefact tests compare against expected files. Records are
//! written as JSON Lines, one object a line, each with `t` (nanoseconds since
//! the run began) and `kind`.
//!
//! ```
//! # use radar::trace::{Record, Entry};
//! let r = Record { t: 5, entry: Entry::Activate { plugin: "TestEvent".into() } };
//! assert_eq!(r.to_json_line(), r#"{"t":5,"kind":"activate","plugin":"TestEvent"}"#);
//! ```

mod check;
pub mod compare;
pub mod inputs;
mod kept;
mod lines;
mod record;
mod sink;

pub use check::{check, explain, Laws, Violation, WITHDRAWN};
pub(crate) use kept::KeptTrace;
pub use lines::{parse_json_lines, to_json_lines, to_values, ParseError};
pub use record::{Entry, Name, Record};
pub(crate) use sink::CLOCK_EVERY;
pub use sink::{JsonLines, TraceSink};
