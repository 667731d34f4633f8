//! The data crate's MAT level-5 reader (`pumptwin_data::mat`): every variable of a
//! file that reads is asked for its vector form.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_data::mat;

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
