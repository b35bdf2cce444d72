//! Hot swap fixture, version 1: triggers every second with its count
//! (1, 2, 3, ...); see `counter.rs`.
const SCALE: u32 = 1;
include!("counter.rs");
