//! Fuzz target `payload`: see `radar::testing::fuzz::payload`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| radar::testing::fuzz::payload(data));
