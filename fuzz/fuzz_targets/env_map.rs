//! Fuzz target: `rsl::fuzzing::env_map` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::env_map(data));
