//! Fuzz target: `rsl::fuzzing::rsl_file` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::rsl_file(data));
