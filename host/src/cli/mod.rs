//! The subcommands of `radar`, one module each.

use std::io::Write;

pub mod agent;
pub mod ctl;
pub mod fixes;
pub mod graph;
pub mod ros2;
pub mod run;
pub mod run_args;
pub mod shadow;
pub mod shown;
pub mod simulate;
pub mod test;
pub mod tool;
pub mod trace;
pub mod view;
pub mod workspace;

/// Prints a line; a closed stdout (`radar run | head`) is not an error.
pub fn say(line: std::fmt::Arguments<'_>) {
    let _ = writeln!(std::io::stdout(), "{line}");
}
