//! A plugin's (or a program's) tables in a manifest, as `radar new` writes
//! them: into the plugin folder's own `radar.toml`, or into the system's
//! that holds the folder, with paths through it.

/// A plugin's tables in a manifest (`[plugins.NAME]`, its `[build]` and,
/// for a script, its `[release]`), with paths relative to the plugin's
/// folder.
pub(super) struct Tables {
    /// A deliberative program's (`[deliberative]`), not a plugin's.
    pub program: bool,
    /// The component `radar run` loads: the plugin's, or its world's
    /// development runtime.
    pub wasm: String,
    /// The script run on the development runtime (`app.py`), if any.
    pub source: Option<&'static str>,
    /// The build command and what it watches (a TOML array).
    pub command: String,
    pub watch: String,
    /// For a script: the self-contained component's command, file and
    /// sources.
    pub release: Option<Release>,
}

/// `[plugins.NAME.release]`.
pub(super) struct Release {
    pub command: String,
    pub wasm: String,
    pub watch: String,
}

impl Tables {
    /// The tables as TOML, for a manifest in the plugin's own folder
    /// (`folder` None) or in the system folder that holds it (`folder` its
    /// name: paths go through it and the builds run in it).
    pub(super) fn render(&self, name: &str, folder: Option<&str>) -> String {
        let path = |p: &str| folder.map_or_else(|| p.to_string(), |f| format!("{f}/{p}"));
        let table = if self.program {
            "deliberative".to_string()
        } else {
            format!("plugins.{name}")
        };
        let mut out = format!("[{table}]\nwasm = \"{}\"\n", path(&self.wasm));
        if let Some(source) = self.source {
            out += &format!("source = \"{}\"\n", path(source));
        }
        if !self.program {
            out += "config = { interval_s = 1 }\n";
        }
        out += &format!("\n[{table}.build]\ncommand = \"{}\"\n", self.command);
        if let Some(folder) = folder {
            out += &format!("workdir = \"{folder}\"\n");
        }
        out += &format!("watch = {}\n", self.watch);
        if let Some(release) = &self.release {
            out += &format!(
                "\n[{table}.release]\ncommand = \"{}\"\nwasm = \"{}\"\nwatch = {}\n",
                release.command,
                path(&release.wasm),
                release.watch
            );
        }
        out
    }
}
