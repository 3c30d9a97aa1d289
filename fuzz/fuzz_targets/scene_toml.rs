//! Fuzz target: `rsl::fuzzing::scene_toml` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::scene_toml(data));
