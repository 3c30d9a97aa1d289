//! Fuzz target: `rsl::fuzzing::truth_file` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::truth_file(data));
