//! `control = "local"`: the key that shows a command comes from the user
//! who runs the system, on its machine.
//!
//! The coordinator writes a random key into a file only its OS user can
//! read (a directory of mode 0700, a file of mode 0600, under
//! `$XDG_RUNTIME_DIR/radar` or `/tmp/radar-<uid>`); `radar ctl`, run by the
//! same user on the same machine, finds the same file and sends the key
//! with each command. Another user, or another machine, cannot read it.

use std::io::{Read, Write};
use std::os::unix::fs::{DirBuilderExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

use super::error::NetworkError;

/// The current user's folder for Radar's keys and the components `ctl
/// swap` sends.
pub(super) fn dir() -> PathBuf {
    match std::env::var_os("XDG_RUNTIME_DIR").filter(|d| !d.is_empty()) {
        Some(dir) => PathBuf::from(dir).join("radar"),
        None => PathBuf::from(format!("/tmp/radar-{}", rustix::process::getuid().as_raw())),
    }
}

/// Where the key of system `system` is kept for the current user.
pub(super) fn path(system: &str) -> PathBuf {
    dir().join(format!("{system}.key"))
}

/// Writes `bytes` into a new file at `path` (mode 0600) in a folder only
/// this user may use (made with mode 0700 if it is not there): a folder
/// that someone else made (in /tmp) or others may read is refused.
pub(super) fn write_private(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().map(PathBuf::from).unwrap_or_default();
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(&dir)?;
    let meta = std::fs::symlink_metadata(&dir)?;
    if !meta.is_dir()
        || std::os::unix::fs::MetadataExt::uid(&meta) != rustix::process::getuid().as_raw()
        || meta.permissions().mode() & 0o077 != 0
    {
        return Err(std::io::Error::other(format!(
            "{} belongs to another user or others can use it",
            dir.display()
        )));
    }
    let _ = std::fs::remove_file(path);
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .and_then(|mut f| f.write_all(bytes))
}

/// A file holding a new random key for `system`, removed when dropped.
pub(super) struct KeyFile {
    pub path: PathBuf,
    pub key: String,
}

impl KeyFile {
    pub(super) fn create(system: &str) -> Result<Self, NetworkError> {
        let path = path(system);
        let fail = |cause| NetworkError::Key {
            path: path.clone(),
            cause,
        };
        let mut bytes = [0u8; 16];
        std::fs::File::open("/dev/urandom")
            .and_then(|mut f| f.read_exact(&mut bytes))
            .map_err(fail)?;
        let key: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        write_private(&path, key.as_bytes()).map_err(fail)?;
        Ok(Self { path, key })
    }
}

impl Drop for KeyFile {
    fn drop(&mut self) {
        // Only if it is still ours (another run of the same system may
        // have replaced it).
        if std::fs::read_to_string(&self.path).is_ok_and(|k| k == self.key) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// The key of `system` for the current user, if this user can read it.
pub(super) fn read(system: &str) -> Option<String> {
    std::fs::read_to_string(path(system))
        .ok()
        .map(|k| k.trim().to_string())
}
