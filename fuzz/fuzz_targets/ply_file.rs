//! Fuzz target: `rsl::fuzzing::ply_file` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::ply_file(data));
