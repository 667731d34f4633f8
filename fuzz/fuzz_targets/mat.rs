//! The trainer's MAT level-5 reader, compiled from its own source file
//! (`trainer/src/data/mat.rs`, std-only) into this target: every variable of a file
//! that reads is asked for its vector form.
#![no_main]
#![allow(dead_code)]

use libfuzzer_sys::fuzz_target;

#[path = "../../trainer/src/data/mat.rs"]
mod mat;

fuzz_target!(|data: &[u8]| {
    if let Ok(file) = mat::read_mat(data) {
        for v in &file.variables {
            let _ = v.is_vector();
            let product = v.dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
            assert_eq!(product, Some(v.data.len()), "{}: dims {:?}", v.name, v.dims);
            let _ = file.variable(&v.name);
        }
    }
});
