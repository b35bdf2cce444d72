//! Why `radar new` made nothing: one error type for the plugin folders
//! ([`super::scaffold`]) and the systems they join.

use std::path::PathBuf;

/// Why `radar new` made nothing.
#[derive(Debug, thiserror::Error)]
pub enum ScaffoldError {
    /// The name cannot name a plugin (and, in kebab case, its folder and
    /// WIT world).
    #[error(
        "`{0}` cannot name a plugin: use letters, digits, `-` and `_`, starting with a letter \
         (e.g. `Obstacle`, `BackOff`, `hello-event`)"
    )]
    BadName(String),
    /// The folder is there already.
    #[error("{0} exists already; choose another name or remove it")]
    Exists(PathBuf),
    /// The system's manifest cannot take the new plugin; nothing was made.
    #[error("{}: {cause}", path.display())]
    System {
        /// The system's `radar.toml`.
        path: PathBuf,
        /// Why.
        cause: String,
    },
    /// A template of `host/templates/` out of step with `radar new`.
    #[error("template {template}: {cause}")]
    Template {
        /// The template's path in Radar's repository.
        template: &'static str,
        /// What does not fit.
        cause: String,
    },
    /// Writing the files failed.
    #[error("cannot write {path}: {cause}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The error.
        cause: std::io::Error,
    },
}
