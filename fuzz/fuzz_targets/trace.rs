//! Fuzz target `trace`: see `radar::testing::fuzz::trace`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| radar::testing::fuzz::trace(data));
