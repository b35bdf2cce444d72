//! Fuzz target `component`: see `radar::testing::fuzz::component`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| radar::testing::fuzz::component(data));
