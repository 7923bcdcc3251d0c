//! See `hikage_devkit::fuzzing::alembic_groom`: any bytes give a value or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    hikage_devkit::fuzzing::alembic_groom(data);
});
