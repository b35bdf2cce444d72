//! The values `radar run`'s flags take, read from their text: `--swap`,
//! `--write`, `--inject` (each at a time) and `--pace`.

use std::path::PathBuf;
use std::time::Duration;

use radar::manifest::parse_duration;
use radar::SwapPolicy;

/// One `--swap`.
#[derive(Clone)]
pub struct Swap {
    pub at: Duration,
    pub plugin: String,
    pub path: PathBuf,
    pub policy: SwapPolicy,
}

/// `--swap AT:Plugin=PATH[:drain|restart]`.
pub fn parse_swap(text: &str) -> Result<Swap, String> {
    let shape = || format!("`{text}`: expected AT:Plugin=PATH[:drain|restart]");
    let (at, rest) = text.split_once(':').ok_or_else(shape)?;
    let (plugin, target) = rest.split_once('=').ok_or_else(shape)?;
    let (path, policy) = match target.rsplit_once(':') {
        Some((path, policy)) if policy == "drain" || policy == "restart" => (path, policy.parse()?),
        _ => (target, SwapPolicy::Drain),
    };
    if plugin.is_empty() || path.is_empty() {
        return Err(shape());
    }
    Ok(Swap {
        at: parse_duration(at)?,
        plugin: plugin.to_string(),
        path: PathBuf::from(path),
        policy,
    })
}

/// One `--write`.
#[derive(Clone)]
pub struct BoardWrite {
    pub at: Duration,
    pub entry: String,
    pub value: serde_json::Value,
}

/// `--write AT:entry=JSON`.
pub fn parse_write(text: &str) -> Result<BoardWrite, String> {
    let shape = || format!("`{text}`: expected AT:entry=JSON");
    let (at, rest) = text.split_once(':').ok_or_else(shape)?;
    let (entry, value) = rest.split_once('=').ok_or_else(shape)?;
    if entry.is_empty() {
        return Err(shape());
    }
    Ok(BoardWrite {
        at: parse_duration(at)?,
        entry: entry.to_string(),
        value: serde_json::from_str(value).map_err(|e| format!("`{value}` is not JSON: {e}"))?,
    })
}

/// One `--inject`.
#[derive(Clone)]
pub struct Injection {
    pub at: Duration,
    pub slot: String,
    pub payload: serde_json::Value,
}

/// `--inject AT:Plugin.slot[=JSON]`.
pub fn parse_injection(text: &str) -> Result<Injection, String> {
    let (at, rest) = text
        .split_once(':')
        .ok_or_else(|| format!("`{text}`: expected AT:Plugin.slot=JSON"))?;
    let (slot, payload) = rest.split_once('=').unwrap_or((rest, "null"));
    Ok(Injection {
        at: parse_duration(at)?,
        slot: slot.to_string(),
        payload: serde_json::from_str(payload)
            .map_err(|e| format!("`{payload}` is not JSON: {e}"))?,
    })
}

/// `--pace FACTOR`: from 0.001 to 1000000 times the wall clock.
pub fn parse_pace(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(factor) if (0.001..=1_000_000.0).contains(&factor) => Ok(factor),
        _ => Err(format!(
            "`{text}` is not a pace: a number from 0.001 to 1000000 (1: as fast as the wall clock)"
        )),
    }
}
