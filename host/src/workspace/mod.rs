//! The project side of a system: building plugins from their sources
//! (`[plugins.X.build]`, `radar build`), rebuilding and swapping them in as
//! they change (`radar run --watch`), and making new ones (`radar new`,
//! [`scaffold`]), alone or in a system of many (`radar new system`).
//!
//! A build is the plugin's own command, run with `sh -c` in its folder, so
//! every language builds the same way; what it writes is the plugin's `wasm`
//! file. A build that fails is reported by the first line of its output that
//! names an error (the compiler's first error), and changes nothing.

mod build;
pub mod c_toolchain;
mod error;
pub mod scaffold;
mod system;
mod tables;
mod watch;

pub use build::{build, check_script, BuildFailure, Built};
pub use system::create_system;
pub use watch::{watch, WatchEvent};
