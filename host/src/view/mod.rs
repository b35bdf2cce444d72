//! Seeing a run (`docs/view.md`): the trace as MCAP, for Foxglove,
//! Lichtblick, Rerun and any MCAP reader; the connection graph at an
//! instant; the whole run as one HTML page; the same page live, served
//! while the run goes on.
//!
//! An edge: it sees a run only through its trace records.

pub mod brief;
pub mod graph;
mod html;
pub mod mcap;
mod monitor;
mod read;
pub mod topics;

pub use self::brief::brief;
pub use self::graph::{graph_at, Graph};
pub use self::html::{live_page, write_view};
pub use self::mcap::{jsonl_to_mcap, mcap_to_jsonl, McapTrace, ViewError, LEFT_OUT};
pub use self::monitor::{Monitor, MonitorError, MonitorSink, HISTORY as MONITOR_HISTORY};
pub use self::read::{is_mcap, read_trace};
pub use self::topics::{AlsoOnTopics, TopicChannel, TopicMessage, TopicsSlot};
