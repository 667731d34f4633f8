//! What the co-adaptation heads are held to (eqs. 11 and 24): the shape of a node's
//! spectrum (`L_phy`) and the physical parameters Θ_phys (`L_map`). Plain definitions
//! that the dataset (which stores them per window) and the physics embedding (which
//! computes them from the twin) both read.

use pumptwin_core::fft::{power_spectrum, Complex32, Window};

/// Bands of the node-spectrum shape (the `L_phy` target).
pub const SPEC_BANDS: usize = 16;
/// Upper edge of the node-spectrum bands, Hz (the common band limit).
pub const SPEC_MAX_HZ: f32 = 5_000.0;
/// Components of Θ_phys that F_map predicts.
pub const N_THETA: usize = 4;
/// Names of the Θ_phys components, in order.
pub const THETA_NAMES: [&str; N_THETA] = [
    "ln_stiffness_radial_n_per_m",
    "ln_damping_radial_ns_per_m",
    "ln_impact_amplitude",
    "ln_measurement_noise",
];

/// Θ_phys of one record, `NaN` where undefined (see [`crate::physics`]).
pub type Theta = [f32; N_THETA];

/// The shape of a node's spectrum: log10 band energies minus their mean.
///
/// `x` is one window at `fs_hz`; bands split [0, [`SPEC_MAX_HZ`]] evenly.
pub fn spectrum_shape(x: &[f32], fs_hz: f32) -> [f32; SPEC_BANDS] {
    let n = x.len();
    let mut scratch = vec![Complex32::default(); n];
    let mut power = vec![0.0f32; n / 2 + 1];
    let mut out = [0.0f32; SPEC_BANDS];
    if power_spectrum(x, Window::Hann, &mut scratch, &mut power).is_err() {
        return out;
    }
    let df = fs_hz / n as f32;
    let mut energy = [0.0f64; SPEC_BANDS];
    for (k, p) in power.iter().enumerate() {
        let f = k as f32 * df;
        if f >= SPEC_MAX_HZ {
            break;
        }
        let b = ((f / SPEC_MAX_HZ) * SPEC_BANDS as f32) as usize;
        energy[b.min(SPEC_BANDS - 1)] += f64::from(*p);
    }
    let logs: Vec<f64> = energy.iter().map(|e| (e + 1e-20).log10()).collect();
    let mean = logs.iter().sum::<f64>() / SPEC_BANDS as f64;
    for (o, l) in out.iter_mut().zip(&logs) {
        *o = (l - mean) as f32;
    }
    out
}
