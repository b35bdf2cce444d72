//! The key expressions a system uses (`docs/network.md`), all under
//! `radar/<system>/`.

/// Every emission: `radar/<system>/signal/<Plugin>/<signal>`.
pub fn signal(system: &str, plugin: &str, signal: &str) -> String {
    format!("radar/{system}/signal/{plugin}/{signal}")
}

/// Every blackboard write: `radar/<system>/board/<entry>`.
pub fn board(system: &str, entry: &str) -> String {
    format!("radar/{system}/board/{entry}")
}

/// A put here writes blackboard entries: `radar/<system>/write/<entry>`.
pub fn write(system: &str, entry: &str) -> String {
    format!("radar/{system}/write/{entry}")
}

/// A put here injects into a slot: `radar/<system>/inject/<Plugin>/<slot>`.
pub fn inject(system: &str, plugin: &str, slot: &str) -> String {
    format!("radar/{system}/inject/{plugin}/{slot}")
}

/// Every trace record, as one line of JSON.
pub fn trace(system: &str) -> String {
    format!("radar/{system}/trace")
}

/// The queryable `radar ctl` asks.
pub fn control(system: &str) -> String {
    format!("radar/{system}/control")
}

/// The system's liveliness token.
pub fn alive(system: &str) -> String {
    format!("radar/{system}/alive")
}

/// A plugin's liveliness token.
pub fn alive_plugin(system: &str, plugin: &str) -> String {
    format!("radar/{system}/alive/plugin/{plugin}")
}

/// What coordinators send agent `node`.
pub fn agent_in(node: &str) -> String {
    format!("radar/@agent/{node}/in")
}

/// What agent `node` sends the coordinator of `system`.
pub fn agent_out(system: &str, node: &str) -> String {
    format!("radar/{system}/agent/{node}")
}

/// Agent `node`'s liveliness token.
pub fn agent_alive(node: &str) -> String {
    format!("radar/@agent/{node}/alive")
}

/// Every agent's liveliness token.
pub const ALL_AGENTS: &str = "radar/@agent/*/alive";

/// The agent named by a liveliness key (`radar/@agent/<node>/alive`).
pub fn agent_of(key: &str) -> Option<&str> {
    key.strip_prefix("radar/@agent/")?.strip_suffix("/alive")
}

/// Every system's liveliness token, for discovery.
pub const ALL_SYSTEMS: &str = "radar/*/alive";

/// The system named by a liveliness key (`radar/<system>/alive`).
pub fn system_of(key: &str) -> Option<&str> {
    key.strip_prefix("radar/")?.strip_suffix("/alive")
}

/// Whether `name` can be one chunk of a key expression (no `/`, no
/// wildcard or reserved character, not empty).
pub fn is_chunk(name: &str) -> bool {
    !name.is_empty() && !name.contains(['/', '*', '$', '?', '#', ' '])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_follow_the_documented_shapes() {
        assert_eq!(
            signal("rover", "Obstacle", "triggered"),
            "radar/rover/signal/Obstacle/triggered"
        );
        assert_eq!(
            inject("rover", "Avoid", "start"),
            "radar/rover/inject/Avoid/start"
        );
        assert_eq!(system_of(&alive("rover")), Some("rover"));
        assert!(is_chunk("range_m") && !is_chunk("a/b") && !is_chunk("*") && !is_chunk(""));
    }
}
