//! Reading a trace file, JSON Lines or MCAP (by its extension), into
//! records: what the views start from.

use std::path::Path;

use super::mcap::{mcap_to_jsonl, ViewError};
use crate::trace::{parse_json_lines, Record};

/// Whether a trace file at `path` is MCAP (by its extension, `.mcap`);
/// any other is JSON Lines.
pub fn is_mcap(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// The records of the trace at `path` (`.mcap`: MCAP; else JSON Lines).
pub fn read_trace(path: &Path) -> Result<Vec<Record>, ViewError> {
    let bytes = std::fs::read(path)?;
    let text = if is_mcap(path) {
        let mut lines = Vec::new();
        mcap_to_jsonl(&bytes, &mut lines)?;
        String::from_utf8(lines)
            .map_err(|_| ViewError::NotARecord("a message is not UTF-8".into()))?
    } else {
        String::from_utf8(bytes)
            .map_err(|_| ViewError::NotARecord("the file is not UTF-8 text".into()))?
    };
    parse_json_lines(&text).map_err(|e| ViewError::NotARecord(e.to_string()))
}
