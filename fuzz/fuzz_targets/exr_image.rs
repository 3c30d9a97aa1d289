//! Fuzz target: `rsl::fuzzing::exr_image` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::exr_image(data));
