//! Plugins whose code is data: a development runtime component (built once
//! per plugin world, e.g. `guest-sdk/python/build --dev`) plus the plugin's
//! script files, which the host passes the runtime as the configuration
//! value [`SCRIPT_KEY`]. An edit of the script is a new version of the
//! plugin made of the same compiled component and the new text: swapping
//! it in needs no build and no compile, only a new instance.
//!
//! A plugin's version is then the first 12 hex digits of the sha256 of its
//! component's version and its packed script together, so the same runtime
//! and the same script are the same version, whichever file they came from.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use crate::error::RadarError;

/// The configuration key a development runtime reads its plugin's script
/// from (not listed by `config.keys()`).
pub const SCRIPT_KEY: &str = "radar.source";

/// Languages whose plugins can be scripts, by file extension.
const SCRIPT_EXTENSIONS: [&str; 2] = ["py", "js"];

/// Whether `path` names a script (a `.py` or `.js` file) rather than a
/// component.
pub fn is_script(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| SCRIPT_EXTENSIONS.contains(&e))
}

/// The script files that go with `main`: every file of its language in its
/// folder (not below it), by name.
pub fn files(main: &Path) -> std::io::Result<Vec<std::path::PathBuf>> {
    let extension = main.extension().unwrap_or_default();
    let folder = main.parent().unwrap_or(Path::new("."));
    let folder = if folder.as_os_str().is_empty() {
        Path::new(".")
    } else {
        folder
    };
    let mut found: Vec<_> = std::fs::read_dir(folder)?
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension() == Some(extension))
        .collect();
    found.sort();
    Ok(found)
}

/// Packs the script whose main module is `main` (`app.py`: module `app`)
/// with the other files of its folder, as the runtime reads it:
/// `{"module": "app", "files": {"app.py": "...", ...}}`, keys sorted.
pub(crate) fn pack(plugin: &str, main: &Path) -> Result<Arc<str>, RadarError> {
    let read_error = |path: &Path, cause| RadarError::Read {
        plugin: plugin.into(),
        path: path.to_path_buf(),
        cause,
    };
    let module =
        main.file_stem()
            .and_then(|s| s.to_str())
            .ok_or_else(|| RadarError::BadSetting {
                plugin: plugin.into(),
                cause: format!("{} is not a script file name", main.display()),
            })?;
    std::fs::metadata(main).map_err(|e| read_error(main, e))?;
    let mut texts = BTreeMap::new();
    for path in files(main).map_err(|e| read_error(main, e))? {
        let text = std::fs::read_to_string(&path).map_err(|e| read_error(&path, e))?;
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        texts.insert(name.into_owned(), text);
    }
    let packed = serde_json::json!({ "module": module, "files": texts });
    Ok(packed.to_string().into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_script_is_packed_with_the_modules_beside_it() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::write(dir.path().join("app.py"), "import helper\n").expect("write");
        std::fs::write(dir.path().join("helper.py"), "X = 1\n").expect("write");
        std::fs::write(dir.path().join("notes.txt"), "not code").expect("write");
        let packed = pack("P", &dir.path().join("app.py")).expect("packs");
        let value: serde_json::Value = serde_json::from_str(&packed).expect("json");
        assert_eq!(value["module"], "app");
        assert_eq!(value["files"]["app.py"], "import helper\n");
        assert_eq!(value["files"]["helper.py"], "X = 1\n");
        assert!(value["files"].get("notes.txt").is_none());
        assert!(is_script(Path::new("a/app.py")));
        assert!(!is_script(Path::new("a/app.wasm")));
        let missing = pack("P", &dir.path().join("gone.py")).expect_err("no file");
        assert!(missing.to_string().contains("gone.py"), "{missing}");
    }
}
