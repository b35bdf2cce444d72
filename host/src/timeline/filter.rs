//! What the timeline shows (`radar run --show/--hide`, `radar ctl watch`
//! the same): patterns over what a line is about. A line is about its
//! plugin (`BackOff`), its signal or slot (`BackOff.cmd-vel`,
//! `BackOff.start`), a blackboard entry (`scan`) and the plugin that wrote
//! it. `*` matches any text: `*.triggered`, `Obstacle*`. With `--show`,
//! only lines about something shown are printed; `--hide` then takes lines
//! away. Faults, stops, refusals and the program's end are always printed:
//! a hidden fault would mislead.

use crate::trace::Entry;
use crate::view::graph::plugin_of;
use crate::view::Graph;

/// The patterns a timeline filters its lines with.
#[derive(Clone, Debug, Default)]
pub struct Filter {
    show: Vec<String>,
    hide: Vec<String>,
}

impl Filter {
    /// Shows what matches one of `show` (everything if it is empty),
    /// except what matches one of `hide`. Patterns may be given
    /// comma-separated.
    pub fn new(show: &[String], hide: &[String]) -> Self {
        let split = |patterns: &[String]| -> Vec<String> {
            patterns
                .iter()
                .flat_map(|p| p.split(','))
                .map(str::trim)
                .filter(|p| !p.is_empty())
                .map(str::to_string)
                .collect()
        };
        Self {
            show: split(show),
            hide: split(hide),
        }
    }

    /// Whether the filter lets everything through.
    pub fn is_open(&self) -> bool {
        self.show.is_empty() && self.hide.is_empty()
    }

    /// Whether a line about `subjects` is printed.
    pub fn shows(&self, subjects: &[&str]) -> bool {
        let any = |patterns: &[String]| {
            patterns
                .iter()
                .any(|p| subjects.iter().any(|s| matches(p, s)))
        };
        (self.show.is_empty() || any(&self.show)) && !any(&self.hide)
    }

    /// Whether the line of `entry` is printed (`graph`: the system before
    /// the record, for a disconnection's ends).
    pub fn shows_entry(&self, entry: &Entry, graph: &Graph) -> bool {
        if self.is_open() {
            return true;
        }
        let owned: Vec<String> = match entry {
            Entry::Fault { .. }
            | Entry::Stopped { .. }
            | Entry::Refused { .. }
            | Entry::ProgramEnd { .. } => return true,
            Entry::Signal { plugin, signal, .. } => {
                vec![plugin.to_string(), format!("{plugin}.{signal}")]
            }
            Entry::BoardWrite { entry, by, .. } => vec![entry.clone(), by.to_string()],
            Entry::Connect { from, to, .. } => ends(from, to),
            Entry::Disconnect { id, .. } => match graph.connections.get(id) {
                Some(c) => ends(&c.from, &c.to),
                None => Vec::new(),
            },
            Entry::Inject { to, .. } => vec![plugin_of(to).to_string(), to.to_string()],
            // A delivery is about its slot and the signal it carries.
            Entry::Dropped { id, to, .. } | Entry::Deliver { id, to, .. } => {
                let mut subjects = vec![plugin_of(to).to_string(), to.to_string()];
                if let Some(c) = graph.connections.get(id) {
                    subjects.extend([plugin_of(&c.from).to_string(), c.from.clone()]);
                }
                subjects
            }
            Entry::Activate { plugin }
            | Entry::Deactivate { plugin }
            | Entry::Discarded { plugin, .. }
            | Entry::Reset { plugin }
            | Entry::Log { plugin, .. }
            | Entry::SwapRequest { plugin, .. }
            | Entry::Swap { plugin, .. }
            | Entry::SwapRefused { plugin, .. }
            | Entry::SwapRolledBack { plugin, .. }
            | Entry::State { plugin, .. }
            | Entry::SlotEnd { plugin, .. }
            | Entry::Configured { plugin, .. } => vec![plugin.to_string()],
            Entry::SlotBegin { plugin, slot, .. } => {
                vec![plugin.to_string(), format!("{plugin}.{slot}")]
            }
        };
        let subjects: Vec<&str> = owned.iter().map(String::as_str).collect();
        self.shows(&subjects)
    }
}

/// A connection's subjects: both plugins, the signal and the slot.
fn ends(from: &str, to: &str) -> Vec<String> {
    vec![
        plugin_of(from).to_string(),
        plugin_of(to).to_string(),
        from.to_string(),
        to.to_string(),
    ]
}

/// Whether `pattern` (`*` any text) matches all of `text`.
fn matches(pattern: &str, text: &str) -> bool {
    let parts: Vec<&str> = pattern.split('*').collect();
    if parts.len() == 1 {
        return pattern == text;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !text.starts_with(first) || text.len() < first.len() + last.len() || !text.ends_with(last) {
        return false;
    }
    let mut rest = &text[first.len()..text.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_match_whole_names_with_stars() {
        assert!(matches("BackOff", "BackOff"));
        assert!(!matches("Back", "BackOff"));
        assert!(matches("*.triggered", "Obstacle.triggered"));
        assert!(matches("Obst*", "Obstacle"));
        assert!(matches("*a*c*", "abc"));
        assert!(!matches("*.started", "Obstacle.triggered"));
        assert!(matches("*", "anything"));
    }

    #[test]
    fn show_keeps_what_matches_and_hide_takes_away() {
        let filter = Filter::new(&["BackOff,Obstacle".into()], &["BackOff.moving".into()]);
        assert!(filter.shows(&["BackOff", "BackOff.cmd-vel"]));
        assert!(!filter.shows(&["BackOff", "BackOff.moving"]));
        assert!(!filter.shows(&["scan", "ros2"]));
        let hide_only = Filter::new(&[], &["scan".into()]);
        assert!(hide_only.shows(&["BackOff"]));
        assert!(!hide_only.shows(&["scan", "ros2"]));
    }
}
