//! Fuzz target: `rsl::fuzzing::svdf_file` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::svdf_file(data));
