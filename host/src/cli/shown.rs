//! How the human views of `radar run` and `radar ctl` print a run: values
//! brief or whole, and which lines (`docs/cli.md#what-the-timeline-shows`).

use radar::timeline::{Filter, TimelineOptions};

/// The flags that choose what a timeline prints.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct TimelineArgs {
    /// Print values whole, and every write of an entry written faster than
    /// once a second (by default a large value is summarised: a list by its
    /// length, min, max, mean and first items; a stream by one write a
    /// second and a count of the rest).
    #[arg(long)]
    full: bool,
    /// Print only lines about these (repeatable, or comma-separated): a
    /// plugin (`BackOff`), a signal or slot (`BackOff.cmd-vel`), a
    /// blackboard entry (`scan`); `*` matches any text (`*.triggered`).
    /// Faults, stops and refusals are always printed.
    #[arg(long, value_name = "WHAT")]
    show: Vec<String>,
    /// Do not print lines about these (as --show).
    #[arg(long, value_name = "WHAT")]
    hide: Vec<String>,
}

impl TimelineArgs {
    /// The timeline's options.
    pub fn options(&self) -> TimelineOptions {
        TimelineOptions {
            full: self.full,
            filter: Filter::new(&self.show, &self.hide),
        }
    }
}
