//! A shadow swap (`radar test --shadow RECORDING Plugin=NEW.wasm`,
//! `docs/hot-swap.md#shadow`): before a new version replaces a plugin in a
//! running system, run it on the inputs the system has recorded so far,
//! under the virtual clock, beside the version that ran, and show the
//! first place where the two traces part. So a swap is made knowing what
//! changes.
//!
//! Both runs are replays of the recording: the recorded one runs the
//! components the recording began with (and its recorded swaps), the
//! shadow runs the new version of the plugin from the start instead (its
//! recorded swaps left out), everything else alike.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::clock::ClockKind;
use crate::manifest::Manifest;
use crate::system::{RunReport, System};
use crate::trace::compare::{compare, Comparison, Divergence};
use crate::trace::inputs::{Input, TimedInput};
use crate::trace::to_values;

/// Two runs of one recording, with the old and the new version of a
/// plugin.
pub struct Shadow {
    /// The plugin.
    pub plugin: String,
    /// The version that ran (the recording's), and the new one.
    pub versions: (String, String),
    /// The run as recorded.
    pub recorded: RunReport,
    /// The run with the new version.
    pub shadow: RunReport,
    /// Where the traces first part, if they do: the recorded trace on
    /// the left, the shadow's on the right.
    pub divergence: Option<Divergence>,
}

/// The manifest a recording names, when it names one.
pub fn recorded_manifest(inputs: &[TimedInput]) -> Option<PathBuf> {
    inputs.iter().find_map(|i| match &i.input {
        Input::Recording {
            manifest: Some(path),
            ..
        } => Some(PathBuf::from(path)),
        _ => None,
    })
}

/// How long the recorded run lasted.
fn recorded_end(inputs: &[TimedInput]) -> Option<Duration> {
    inputs.iter().find_map(|i| match i.input {
        Input::End { .. } => Some(Duration::from_nanos(i.t)),
        _ => None,
    })
}

/// Runs `inputs` (a recording) against the system of `manifest` twice:
/// as recorded, and with `plugin` replaced from the start by the
/// component (or script) at `new`; for as long as the recorded run
/// lasted, or `until` (a recording still being made has no end yet).
pub fn shadow(
    manifest: &Path,
    inputs: &[TimedInput],
    plugin: &str,
    new: &Path,
    until: Option<Duration>,
) -> Result<Shadow, String> {
    let run_for = until.or_else(|| recorded_end(inputs)).ok_or(
        "the recording has no `end` line (its run did not finish): a shadow runs as long as \
         the recorded run did",
    )?;
    let load = || -> Result<Manifest, String> {
        let mut manifest = Manifest::load(manifest).map_err(|e| e.to_string())?;
        manifest.run_everything_here();
        Ok(manifest)
    };
    let run = |manifest: &Manifest, inputs: &[TimedInput]| -> Result<(System, Duration), String> {
        let builder = System::builder()
            .clock(ClockKind::Virtual)
            .trace_limit(None);
        let system = manifest
            .add_to(builder)
            .inputs(inputs)
            .build()
            .map_err(|e| e.to_string())?;
        Ok((system, run_for))
    };
    let recorded_manifest = load()?;
    if !recorded_manifest.plugins.contains_key(plugin) {
        let hint =
            crate::suggest::hint(plugin, recorded_manifest.plugins.keys().map(String::as_str));
        return Err(format!("the system has no plugin `{plugin}`{hint}"));
    }
    let (system, limit) = run(&recorded_manifest, inputs)?;
    let old_version = system.versions().get(plugin).cloned().unwrap_or_default();
    let recorded = system.run(Some(limit)).map_err(|e| e.to_string())?;

    // The shadow: the new version from the start, the plugin's recorded
    // versions and swaps left out.
    let mut shadow_manifest = load()?;
    let entry = shadow_manifest
        .plugins
        .get_mut(plugin)
        .ok_or_else(|| format!("the system has no plugin `{plugin}`"))?;
    let new = std::path::absolute(new).unwrap_or_else(|_| new.to_path_buf());
    if crate::script::is_script(&new) && entry.source.is_some() {
        entry.source = Some(new);
    } else {
        entry.wasm = new;
        entry.source = None;
    }
    let shadow_inputs: Vec<TimedInput> = inputs
        .iter()
        .filter(|i| match &i.input {
            Input::Plugin { plugin: p, .. } | Input::Swap { plugin: p, .. } => p != plugin,
            _ => true,
        })
        .cloned()
        .collect();
    let (system, limit) = run(&shadow_manifest, &shadow_inputs)?;
    let new_version = system.versions().get(plugin).cloned().unwrap_or_default();
    let shadow = system.run(Some(limit)).map_err(|e| e.to_string())?;
    let divergence = compare(
        &to_values(&recorded.trace),
        &to_values(&shadow.trace),
        &Comparison::default(),
    );
    Ok(Shadow {
        plugin: plugin.to_string(),
        versions: (old_version, new_version),
        recorded,
        shadow,
        divergence,
    })
}

impl Shadow {
    /// What `radar test --shadow` and `radar ctl swap --shadow` print: a
    /// line each (`new` names the new version's file, `on` the recording).
    pub fn report(&self, new: &str, on: &str) -> Vec<String> {
        let (old, new_version) = &self.versions;
        let mut lines = vec![format!(
            "shadow of {}: version {old} (as recorded) beside {new_version} ({new}), on {on} \
             ({:.3} s, virtual clock)",
            self.plugin,
            self.recorded.ended_at.as_secs_f64()
        )];
        let Some(divergence) = &self.divergence else {
            lines.push(
                "the traces do not part: on these inputs the new version does what the old one \
                 did"
                .into(),
            );
            return lines;
        };
        let text = divergence.named(["as recorded", "in the shadow", "as recorded", "shadow"]);
        let mut parts = text.trim_end().lines();
        lines.push(format!(
            "the traces part: {}",
            parts.next().unwrap_or_default()
        ));
        lines.extend(parts.map(str::to_string));
        let counts = self.signal_counts();
        if !counts.is_empty() {
            lines.push("signals, as recorded → shadow:".into());
            lines.extend(counts.into_iter().map(|c| format!("  {c}")));
        }
        for (what, report) in [("recorded run", &self.recorded), ("shadow", &self.shadow)] {
            if let Some(crate::system::FirstFault {
                plugin, at, cause, ..
            }) = &report.first_fault
            {
                lines.push(format!(
                    "{what}: {plugin} faulted at {:.3} s: {cause}",
                    at.as_secs_f64()
                ));
            }
        }
        lines
    }

    /// What each run's plugins emitted, where the counts differ: `name:
    /// recorded → shadow`, a line each.
    pub fn signal_counts(&self) -> Vec<String> {
        use std::collections::BTreeMap;
        let count = |report: &RunReport| {
            let mut counts: BTreeMap<String, u64> = BTreeMap::new();
            for r in &report.trace {
                if let crate::trace::Entry::Signal { plugin, signal, .. } = &r.entry {
                    *counts.entry(format!("{plugin}.{signal}")).or_default() += 1;
                }
            }
            counts
        };
        let (old, new) = (count(&self.recorded), count(&self.shadow));
        let mut names: Vec<&String> = old.keys().chain(new.keys()).collect();
        names.sort();
        names.dedup();
        names
            .into_iter()
            .filter_map(|name| {
                let (a, b) = (
                    old.get(name).copied().unwrap_or(0),
                    new.get(name).copied().unwrap_or(0),
                );
                (a != b).then(|| format!("{name}: {a} → {b}"))
            })
            .collect()
    }
}
