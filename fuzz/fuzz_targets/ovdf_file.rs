//! Fuzz target: `rsl::fuzzing::ovdf_file` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::ovdf_file(data));
