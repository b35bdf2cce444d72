//! Fuzz target `manifest`: see `radar::testing::fuzz::manifest`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| radar::testing::fuzz::manifest(data));
