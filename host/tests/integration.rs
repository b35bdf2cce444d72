//! The host's integration tests, one module per file beside this one,
//! built as one test binary: each binary links wasmtime, zenoh and the
//! host, so one binary instead of one a file roughly halves the time a
//! fresh build spends on test binaries (CONTRIBUTING.md has the figures),
//! and the tests of every file share the test threads (a file's last slow
//! test no longer leaves a core idle). Run one file's tests with
//! `cargo test --release -p radar --test integration view::`.

mod common;

mod agents;
mod architecture;
mod cli;
mod graph;
mod large_values;
mod lost_link;
mod mcap;
mod network;
mod program_end;
mod ros2;
mod ros2_actions;
mod ros2_agents;
mod ros2_clock;
#[cfg(feature = "dds")]
mod ros2_dds;
#[cfg(feature = "dds")]
mod ros2_dds_time;
mod ros2_parameters;
mod ros2_replay;
mod ros2_services;
mod scaffold;
mod scenarios;
mod simulate;
mod stopping;
mod view;
mod wasmtime_facts;
