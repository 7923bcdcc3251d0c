//! See `hikage_devkit::fuzzing::mesh`: any bytes give a mesh or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    hikage_devkit::fuzzing::mesh(data);
});
