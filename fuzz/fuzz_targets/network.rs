//! Fuzz target `network`: see `radar::testing::fuzz::network`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| radar::testing::fuzz::network(data));
