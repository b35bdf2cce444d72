//! Seeing a run (`docs/view.md`): the trace as MCAP, for Foxglove,
//! Lichtblick, Rerun and any MCAP reader.
//!
//! An edge: it sees a run only through its trace records.

pub mod mcap;

pub use self::mcap::{jsonl_to_mcap, mcap_to_jsonl, McapTrace, ViewError};
