//! Fuzz target: `rsl::fuzzing::bench_csv` (see its documentation).

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rsl::fuzzing::bench_csv(data));
