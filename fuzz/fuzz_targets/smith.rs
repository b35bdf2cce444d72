//! Fuzz target `smith`: random guest code (wasm-smith) as an event plugin,
//! run by `radar::testing::fuzz::component`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Some(component) = radar_tests::smith::event_component(data) {
        radar::testing::fuzz::component(&component);
    }
});
