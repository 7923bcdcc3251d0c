//! `bundle.ron` text → `Manifest::parse`: any bytes give a manifest or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    hikage_devkit::fuzzing::manifest(data);
});
