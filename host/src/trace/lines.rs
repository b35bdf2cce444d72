//! Traces as JSON Lines, read and written.

use serde_json::Value as Json;

use super::record::Record;

/// A trace file line that is not a record.
#[derive(Debug, thiserror::Error)]
#[error("trace line {line}: {cause}")]
pub struct ParseError {
    /// The line, counting from 1.
    pub line: usize,
    /// What is wrong with it.
    pub cause: String,
}

/// Parses a trace written as JSON Lines (blank lines are skipped).
pub fn parse_json_lines(text: &str) -> Result<Vec<Record>, ParseError> {
    Ok(parse_lines(text)?.into_iter().map(|(_, r)| r).collect())
}

/// Each non-blank line of `text` as a `T`, with its line number (from 1):
/// what trace files, expected traces and inputs files are read with.
pub(crate) fn parse_lines<T: serde::de::DeserializeOwned>(
    text: &str,
) -> Result<Vec<(usize, T)>, ParseError> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            serde_json::from_str(l)
                .map(|value| (i + 1, value))
                .map_err(|e| ParseError {
                    line: i + 1,
                    cause: e.to_string(),
                })
        })
        .collect()
}

/// Records as JSON objects, the form traces are compared in.
pub fn to_values(records: &[Record]) -> Vec<Json> {
    records
        .iter()
        .map(|r| serde_json::to_value(r).unwrap_or_default())
        .collect()
}

/// Renders a whole trace as JSON Lines.
pub fn to_json_lines(records: &[Record]) -> String {
    let mut out = String::new();
    for r in records {
        out.push_str(&r.to_json_line());
        out.push('\n');
    }
    out
}
