//! `radar test --shadow RECORDING Plugin=NEW`: the new version run on a
//! recording beside the version that ran; where the traces part.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use radar::testing::shadow;
use radar::trace::inputs;

use super::say;

pub fn shadow(recording: &str, swap: &str, manifest: Option<&Path>) -> Result<()> {
    let (plugin, path) = swap
        .split_once('=')
        .filter(|(p, n)| !p.is_empty() && !n.is_empty())
        .with_context(|| format!("`{swap}`: expected PLUGIN=PATH, e.g. Avoid=avoid_v2.wasm"))?;
    let inputs = inputs::load(Path::new(recording)).map_err(anyhow::Error::msg)?;
    let manifest = match manifest {
        Some(path) => path.to_path_buf(),
        None => shadow::recorded_manifest(&inputs).with_context(|| {
            format!(
                "{recording} names no manifest (a recording of a built-in example, or of an \
                 older Radar): say which with --manifest radar.toml"
            )
        })?,
    };
    let new = PathBuf::from(path);
    if !new.exists() {
        anyhow::bail!("{}: no such file", new.display());
    }
    let run = shadow::shadow(&manifest, &inputs, plugin, &new, None)
        .map_err(|e| anyhow::anyhow!("shadow of {plugin}: {e}"))?;
    for line in run.report(&new.display().to_string(), recording) {
        say(format_args!("{line}"));
    }
    if run.divergence.is_some() {
        anyhow::bail!("the new version of {plugin} parts from the recorded run");
    }
    Ok(())
}

/// `radar ctl swap --shadow` on a running system: what its recording holds
/// so far, against the manifest it names, run beside the new version.
pub fn on_running_system(job: radar::network::ShadowJob) -> Result<Vec<String>, String> {
    let bytes = std::fs::read(&job.recording).map_err(|e| e.to_string())?;
    let text = String::from_utf8_lossy(&bytes[..(job.len as usize).min(bytes.len())]);
    let dir = job.recording.parent().unwrap_or(Path::new("."));
    let inputs = inputs::parse(&text, dir).map_err(|e| e.to_string())?;
    let manifest = shadow::recorded_manifest(&inputs)
        .ok_or("the run's recording names no manifest (a built-in example)")?;
    let run = shadow::shadow(&manifest, &inputs, &job.plugin, &job.new, Some(job.until))
        .map_err(|e| format!("shadow of {}: {e}", job.plugin))?;
    Ok(run.report(
        &job.file,
        &format!("the inputs recorded so far ({})", job.recording.display()),
    ))
}
