#![no_main]
//! Fuzz target: see `nimbus_fuzz::Target::RootsJson`.

libfuzzer_sys::fuzz_target!(|data: &[u8]| nimbus_fuzz::run(nimbus_fuzz::Target::RootsJson, data));
