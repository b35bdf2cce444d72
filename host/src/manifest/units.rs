//! Sizes and durations as a manifest and the command line write them
//! (`512MiB`, `1.5s`).

use std::time::Duration;

use serde::Deserialize;

/// A size in bytes: a number, or text with a unit (`B`, `KiB`, `MiB`,
/// `GiB`, `KB`, `MB`, `GB`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(try_from = "toml::Value")]
pub struct ByteSize(pub usize);

impl TryFrom<toml::Value> for ByteSize {
    type Error = String;

    fn try_from(value: toml::Value) -> Result<Self, String> {
        match value {
            toml::Value::Integer(n) => usize::try_from(n)
                .map(ByteSize)
                .map_err(|_| format!("{n} is not a size in bytes")),
            toml::Value::String(text) => parse_bytes(&text).map(ByteSize),
            other => Err(format!("{other} is not a size (try 8GiB or 512MiB)")),
        }
    }
}

/// A number with a unit (`1.5s`, `512MiB`): the number and the unit; the
/// error says the text is not `what` (with `try` as examples).
fn number_and_unit<'t>(text: &'t str, what: &str, example: &str) -> Result<(f64, &'t str), String> {
    let text = text.trim();
    let split = text
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let value = number
        .parse()
        .map_err(|_| format!("`{text}` is not {what} (try {example})"))?;
    Ok((value, unit.trim()))
}

/// Parses a size such as `8GiB`, `512MiB`, `64KiB`, `2GB` or `4096`.
pub fn parse_bytes(text: &str) -> Result<usize, String> {
    let (value, unit) = number_and_unit(text, "a size", "8GiB or 512MiB")?;
    let scale: f64 = match unit {
        "" | "B" => 1.0,
        "KiB" => 1024.0,
        "MiB" => 1024.0 * 1024.0,
        "GiB" => 1024.0 * 1024.0 * 1024.0,
        "KB" | "kB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        other => {
            return Err(format!(
                "unknown unit `{other}` in `{text}` (B, KiB, MiB, GiB, KB, MB, GB)"
            ))
        }
    };
    Ok((value * scale) as usize)
}

/// Parses a duration such as `30s`, `500ms`, `1.5s`, `2m` or `100us`.
pub fn parse_duration(text: &str) -> Result<Duration, String> {
    let text = text.trim();
    let (value, unit) = number_and_unit(text, "a duration", "30s, 500ms, 2m")?;
    let scale = match unit {
        "ns" => 1e-9,
        "us" | "µs" => 1e-6,
        "ms" => 1e-3,
        "s" | "" => 1.0,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        other => {
            return Err(format!(
                "unknown unit `{other}` in `{text}` (ns, us, ms, s, m, h)"
            ))
        }
    };
    Duration::try_from_secs_f64(value * scale).map_err(|e| format!("`{text}`: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_parse_with_units() {
        assert_eq!(parse_duration("30s"), Ok(Duration::from_secs(30)));
        assert_eq!(parse_duration("500ms"), Ok(Duration::from_millis(500)));
        assert_eq!(parse_duration("1.5s"), Ok(Duration::from_millis(1500)));
        assert_eq!(parse_duration("2m"), Ok(Duration::from_secs(120)));
        assert!(parse_duration("soon").is_err());
        assert!(parse_duration("5 parsecs").is_err());
    }

    #[test]
    fn sizes_parse_with_units() {
        assert_eq!(parse_bytes("4096"), Ok(4096));
        assert_eq!(parse_bytes("64KiB"), Ok(64 << 10));
        assert_eq!(parse_bytes("1.5GiB"), Ok(3 << 29));
        assert_eq!(parse_bytes("2GB"), Ok(2_000_000_000));
        assert!(parse_bytes("lots").is_err());
        assert!(parse_bytes("3 parsecs").is_err());
    }
}
