//! Fuzz target `inputs`: see `radar::testing::fuzz::inputs`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| radar::testing::fuzz::inputs(data));
