//! The integration tests against the example plugins, one module per file
//! beside this one, built as one test binary: each binary links wasmtime,
//! zenoh and the host, so one binary instead of one a file roughly halves
//! the time a fresh build spends on test binaries (CONTRIBUTING.md has the
//! figures), and the tests of every file share the test threads. Run
//! one file's tests with `cargo test --release -p radar-tests --test
//! integration swap::`.
//!
//! `hostile.rs`, `hostile_io.rs` and `leaks.rs` stay binaries of their
//! own: they measure the process (its resident memory, its mappings),
//! which other tests running beside them would change.

mod common;

mod backed;
mod backed_actions;
mod bad_input;
mod board;
mod board_in_languages;
mod c_languages;
mod commands;
mod config;
mod deliberative;
mod determinism;
mod exits;
mod fuzz;
mod guest_sdk;
mod harness;
mod languages;
mod properties;
mod reload;
mod semantics;
mod semantics_activations;
mod semantics_native;
mod signals;
mod simulate;
mod swap;
mod threads;
