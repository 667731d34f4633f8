//! The data crate's MAT level-5 reader (`pumptwin_data::mat`): every variable of a
//! file that reads (struct fields flattened) is asked for its vector form, and every
//! char array is looked up as text.
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
        for t in &file.texts {
            assert!(file.text(&t.name).is_some(), "{}", t.name);
        }
    }
});
