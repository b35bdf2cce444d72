//! Systems of many plugins: `radar new system NAME` makes a folder with a
//! `radar.toml` of its own, and `radar new event|response NAME`, run in a
//! folder that has a `radar.toml`, makes the plugin's folder there and adds
//! the plugin's tables to that manifest, with paths into the new folder, so
//! that nobody writes `../` paths by hand.
//!
//! The tables are the same a plugin folder's own `radar.toml` holds
//! (`Tables`), rendered relative to the system's folder. The system's
//! manifest is appended to, never rewritten, so its comments and order
//! stay as the user left them; the result is parsed before anything is
//! written, and a plugin name the system has already is refused.

use std::path::{Path, PathBuf};

use super::error::ScaffoldError;
use super::tables::Tables;
use crate::manifest::Manifest;

/// The template of a system's `radar.toml`.
const SYSTEM_MANIFEST: &str = include_str!("../../templates/system.toml");

/// Makes `parent/FOLDER` with the `radar.toml` of the system `name` (no
/// plugins yet: `radar new event|response` in it adds them); returns the
/// folder.
pub fn create_system(parent: &Path, folder: &str, name: &str) -> Result<PathBuf, ScaffoldError> {
    let dir = parent.join(folder);
    if dir.exists() {
        return Err(ScaffoldError::Exists(dir));
    }
    let write = |path: PathBuf, text: String| {
        std::fs::create_dir_all(&dir)
            .and_then(|()| std::fs::write(&path, text))
            .map_err(|cause| ScaffoldError::Write { path, cause })
    };
    write(
        dir.join("radar.toml"),
        SYSTEM_MANIFEST.replace("{{name}}", name),
    )?;
    write(dir.join(".gitignore"), "target/\n".into())?;
    Ok(dir)
}

/// The manifest of the system whose folder is `parent`, if it has one.
pub(super) fn system_manifest(parent: &Path) -> Option<PathBuf> {
    let path = parent.join("radar.toml");
    path.is_file().then_some(path)
}

/// The system manifest at `path` with the tables of the plugin `name`
/// added (paths into its folder `folder`), checked; the caller writes it
/// once the plugin's folder is made.
pub(super) fn with_plugin(
    path: &Path,
    name: &str,
    folder: &str,
    tables: &Tables,
) -> Result<String, ScaffoldError> {
    let refused = |cause: String| ScaffoldError::System {
        path: path.to_path_buf(),
        cause,
    };
    let text = std::fs::read_to_string(path).map_err(|e| refused(e.to_string()))?;
    let existing: toml::Table = toml::from_str(&text).map_err(|e| {
        refused(format!(
            "it does not parse ({}); mend it, then add the plugin",
            e.message().trim()
        ))
    })?;
    if tables.program && existing.contains_key("deliberative") {
        return Err(refused(
            "the system has a [deliberative] program already (one a system)".into(),
        ));
    }
    let has = existing
        .get("plugins")
        .and_then(|p| p.as_table())
        .is_some_and(|p| p.contains_key(name));
    if has && !tables.program {
        return Err(refused(format!("the system has a plugin `{name}` already")));
    }
    let mut combined = text;
    if !combined.is_empty() && !combined.ends_with('\n') {
        combined.push('\n');
    }
    combined.push('\n');
    combined.push_str(&tables.render(name, Some(folder)));
    let dir = path.parent().unwrap_or(Path::new("."));
    // A program may come first, into a system with no plugins yet (which
    // does not run until one is added).
    let no_plugins = existing
        .get("plugins")
        .and_then(|p| p.as_table())
        .is_none_or(|p| p.is_empty());
    if !(tables.program && no_plugins) {
        Manifest::parse(&combined, path, dir).map_err(|e| refused(e.to_string()))?;
    }
    Ok(combined)
}

#[cfg(test)]
mod tests {
    use super::super::tables::Release;
    use super::*;

    fn script_tables() -> Tables {
        Tables {
            program: false,
            wasm: "target/dev.wasm".into(),
            source: Some("app.py"),
            command: "sh tools/build --dev target/dev.wasm".into(),
            watch: r#"["wit/**/*.wit"]"#.into(),
            release: Some(Release {
                command: "sh tools/build target/eye.wasm".into(),
                wasm: "target/eye.wasm".into(),
                watch: r#"["*.py"]"#.into(),
            }),
        }
    }

    #[test]
    fn tables_in_a_system_point_into_the_plugins_folder() {
        let own = script_tables().render("eye", None);
        assert!(own.contains("wasm = \"target/dev.wasm\"\nsource = \"app.py\""));
        assert!(!own.contains("workdir"));
        let dir = tempfile::tempdir().expect("temp dir");
        let system = create_system(dir.path(), "robot", "robot").expect("made");
        let manifest = system.join("radar.toml");
        let text = with_plugin(&manifest, "eye", "eye", &script_tables()).expect("added");
        assert!(
            text.starts_with("# The system `robot`"),
            "comments kept: {text}"
        );
        let parsed = Manifest::parse(&text, &manifest, &system).expect("parses");
        let builds = parsed.builds();
        assert_eq!(builds[0].workdir, system.join("eye"));
        assert_eq!(builds[0].wasm, system.join("eye/target/dev.wasm"));
        assert_eq!(builds[0].script, Some(system.join("eye/app.py")));
        std::fs::write(&manifest, &text).expect("write");
        let again = with_plugin(&manifest, "eye", "eye", &script_tables()).expect_err("twice");
        assert!(
            again.to_string().contains("has a plugin `eye` already"),
            "{again}"
        );
    }

    #[test]
    fn a_program_may_come_first_into_an_empty_system_and_only_once() {
        let dir = tempfile::tempdir().expect("temp dir");
        let system = create_system(dir.path(), "robot", "robot").expect("made");
        let manifest = system.join("radar.toml");
        let program = Tables {
            program: true,
            ..script_tables()
        };
        let text = with_plugin(&manifest, "wiring", "wiring", &program).expect("added");
        assert!(
            text.contains("[deliberative]\nwasm = \"wiring/target/dev.wasm\""),
            "{text}"
        );
        std::fs::write(&manifest, &text).expect("write");
        let again = with_plugin(&manifest, "other", "other", &program).expect_err("a second");
        assert!(again.to_string().contains("program already"), "{again}");
    }
}
