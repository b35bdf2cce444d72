//! Seeing a run (`docs/view.md`): the trace as MCAP, for Foxglove,
//! Lichtblick, Rerun and any MCAP reader; the connection graph at an
//! instant.
//!
//! An edge: it sees a run only through its trace records.

pub mod graph;
pub mod mcap;
mod read;

pub use self::graph::{graph_at, Graph};
pub use self::mcap::{jsonl_to_mcap, mcap_to_jsonl, McapTrace, ViewError};
pub use self::read::{is_mcap, read_trace};
