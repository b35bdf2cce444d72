//! Hot swap fixture, version 2 of `counter-event`: the same count and state,
//! triggered with the count × 100.
const SCALE: u32 = 100;
include!("../../counter-event/src/counter.rs");
