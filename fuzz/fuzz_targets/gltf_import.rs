//! Fuzz target: `rsl::fuzzing::gltf_import` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::gltf_import(data));
