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
    let run = shadow::shadow(&manifest, &inputs, plugin, &new)
        .map_err(|e| anyhow::anyhow!("shadow of {plugin}: {e}"))?;
    let (old, new_version) = &run.versions;
    say(format_args!(
        "shadow of {plugin}: version {old} (as recorded) beside {new_version} ({}), on {recording} \
         ({:.3} s, virtual clock)",
        new.display(),
        run.recorded.ended_at.as_secs_f64()
    ));
    match &run.divergence {
        None => {
            say(format_args!(
                "the traces do not part: on these inputs the new version does what the old one did"
            ));
            Ok(())
        }
        Some(divergence) => {
            say(format_args!(
                "the traces part: {}",
                divergence
                    .named(["as recorded", "in the shadow", "as recorded", "shadow"])
                    .trim_end()
            ));
            let counts = run.signal_counts();
            if !counts.is_empty() {
                say(format_args!("signals, as recorded → shadow:"));
                for line in counts {
                    say(format_args!("  {line}"));
                }
            }
            for (what, report) in [("recorded run", &run.recorded), ("shadow", &run.shadow)] {
                if let Some((plugin, at, cause)) = &report.first_fault {
                    say(format_args!(
                        "{what}: {plugin} faulted at {:.3} s: {cause}",
                        at.as_secs_f64()
                    ));
                }
            }
            anyhow::bail!("the new version of {plugin} parts from the recorded run")
        }
    }
}
