//! Int8 GRU cell (paper eq. 7), with its float reference.
//!
//! Gate order and equations (the paper's form, "reset before `U`"; PyTorch's
//! `nn.GRU` applies `r` *after* `U_n` and has a second bias — the trainer must
//! export this form):
//!
//! ```text
//! z  = σ( W_z x + b_z + U_z h )            update gate           (7a)
//! r  = σ( W_r x + b_r + U_r h )            reset gate            (7b)
//! ñ  = tanh( W_n x + b_n + U_n (r ⊙ h) )   candidate             (7c)
//! h' = (1 − z) ⊙ h + z ⊙ ñ                 new hidden state      (7d)
//! ```
//!
//! Int8 data flow (scales in brackets; no floats):
//!
//! ```text
//! pre_g = requant_g( W_gq·xq + b_gq + M_g(U_gq·hq) )   [range_g/127]  g ∈ {z, r, n}
//!         (M_g[o] ≈ s_h·s_u[o] / (s_x·s_w[o]) puts U's accumulator on W's scale)
//! zq, rq = SigmoidLut(pre)                             [1/127], codes 0..=127
//! rhq    = round(rq·hq / 127)                          [1/127]
//! ñq     = TanhLut(pre_n)                              [1/127]
//! h'q    = round(((127 − zq)·hq + zq·ñq) / 127)        [1/127]  (convex: stays in ±127)
//! ```
//!
//! The hidden state has the fixed scale `1/127` ([`GruCell::HIDDEN_SCALE`]): `tanh`
//! and the convex combination keep `|h| ≤ 1`. Gate pre-activations clamp to `±6`
//! (sigmoid) and `±3` (tanh), see [`super::lut`].
//!
//! # Shapes
//! - `x`: `[IN]` at the input scale `s_x`; `h`: `[H]` at 1/127
//! - `W_z, W_r, W_n`: `[H][IN]` with biases `[H]`; `U_z, U_r, U_n`: `[H][H]`, no bias
//!
//! # Tolerance (measured, tested)
//! Against [`GruCellF32`] on the dequantized inputs, both starting from `h = 0` and
//! each carrying its own state for `T = 48` steps (400 random cells, `IN = 8`,
//! `H = 16`, weights up to `2/√fan_in`): every hidden unit at every step is within
//! [`GRU_DRIFT_BOUND`] `= 0.06` (7.6 LSB of 1/127). Measured: max 0.031 (3.9 LSB).
//! The drift does not grow with `T`: over 200 further cells the worst error of steps
//! 32..48 (0.026) is no larger than that of steps 0..32 (0.028); the test allows
//! +1 LSB. Per step the
//! error is a few LSB: input rounding of the gate tables (≤ 1.25 / 2 LSB, see
//! [`super::lut`]), requantization of the pre-activations, the rounding of `r ⊙ h`
//! and of `h'`, and the weight rounding carried through `W` and `U`.

use crate::error::{Error, Result};

use super::arith::{sigmoid_f64, tanh_f64};
use super::linear::{LinearF32, QLinear};
use super::lut::{Lut8, SIGMOID_GATE_INPUT_SCALE, TANH_GATE_INPUT_SCALE};
use super::qparams::{QMultiplier, QScale};

/// Stated bound of the int8 GRU's hidden-state drift from the float reference,
/// `|ĥ − h|` in real units, over the tested runs (see the module docs).
pub const GRU_DRIFT_BOUND: f64 = 0.06;

/// Float reference GRU cell (eq. 7, gate order z, r, n).
#[derive(Debug, Clone, PartialEq)]
pub struct GruCellF32<const IN: usize, const H: usize> {
    /// `W_z`, `b_z`.
    pub w_z: LinearF32<IN, H>,
    /// `W_r`, `b_r`.
    pub w_r: LinearF32<IN, H>,
    /// `W_n`, `b_n`.
    pub w_n: LinearF32<IN, H>,
    /// `U_z`, `[H][H]`.
    pub u_z: [[f32; H]; H],
    /// `U_r`, `[H][H]`.
    pub u_r: [[f32; H]; H],
    /// `U_n`, `[H][H]` (applied to `r ⊙ h`).
    pub u_n: [[f32; H]; H],
}

impl<const IN: usize, const H: usize> GruCellF32<IN, H> {
    /// One step: `h ← GRU(x, h)`.
    pub fn step(&self, x: &[f32; IN], h: &mut [f32; H]) {
        let mut wz = [0f32; H];
        let mut wr = [0f32; H];
        let mut wn = [0f32; H];
        self.w_z.forward(x, &mut wz);
        self.w_r.forward(x, &mut wr);
        self.w_n.forward(x, &mut wn);
        let mut z = [0f32; H];
        let mut rh = [0f32; H];
        for o in 0..H {
            z[o] = sigmoid_f64(f64::from(wz[o] + dot(&self.u_z[o], h))) as f32;
            let r = sigmoid_f64(f64::from(wr[o] + dot(&self.u_r[o], h))) as f32;
            rh[o] = r * h[o];
        }
        for o in 0..H {
            let n = tanh_f64(f64::from(wn[o] + dot(&self.u_n[o], &rh))) as f32;
            h[o] = (1.0 - z[o]) * h[o] + z[o] * n;
        }
    }
}

fn dot<const H: usize>(a: &[f32; H], b: &[f32; H]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Caller-owned scratch of [`GruCell::step`]: `8·H + 4·H` bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GruScratch<const H: usize> {
    acc_w: [i32; H],
    acc_u: [i32; H],
    z: [i8; H],
    r: [i8; H],
    rh: [i8; H],
    n: [i8; H],
}

impl<const H: usize> GruScratch<H> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        Self {
            acc_w: [0; H],
            acc_u: [0; H],
            z: [0; H],
            r: [0; H],
            rh: [0; H],
            n: [0; H],
        }
    }
}

impl<const H: usize> Default for GruScratch<H> {
    fn default() -> Self {
        Self::new()
    }
}

/// One gate's weights: `W_g` (with bias, output at the gate table's input scale),
/// `U_g` (no bias, input at 1/127) and the multipliers that put `U_g`'s accumulator
/// on `W_g`'s.
#[derive(Debug, Clone, PartialEq)]
struct Gate<const IN: usize, const H: usize> {
    w: QLinear<IN, H>,
    u: QLinear<H, H>,
    u_to_w: [QMultiplier; H],
}

impl<const IN: usize, const H: usize> Gate<IN, H> {
    const EMPTY: Self = Self {
        w: QLinear::EMPTY,
        u: QLinear::EMPTY,
        u_to_w: [QMultiplier::INV_127; H],
    };

    fn new(w: QLinear<IN, H>, u: QLinear<H, H>, table_scale: QScale) -> Result<Self> {
        let mut g = Self {
            w,
            u,
            u_to_w: [QMultiplier::INV_127; H],
        };
        g.derive(table_scale)?;
        Ok(g)
    }

    /// Check the matrices and derive `u_to_w` in place.
    fn derive(&mut self, table_scale: QScale) -> Result<()> {
        let (w, u) = (&self.w, &self.u);
        if w.output_scale() != table_scale || u.output_scale() != table_scale {
            return Err(Error::InvalidParameter(
                "GRU gate output scale must be the gate table's input scale",
            ));
        }
        if u.input_scale() != GruCell::<IN, H>::HIDDEN_SCALE || u.bias().iter().any(|&b| b != 0) {
            return Err(Error::InvalidParameter(
                "GRU U matrices take h at 1/127 and have no bias",
            ));
        }
        for o in 0..H {
            let num = f64::from(u.input_scale().get()) * f64::from(u.weight_scales()[o].get());
            let den = f64::from(w.input_scale().get()) * f64::from(w.weight_scales()[o].get());
            self.u_to_w[o] = QMultiplier::from_f64(num / den).ok_or(Error::InvalidParameter(
                "GRU U/W scale ratio outside [2^-32, 2^31)",
            ))?;
        }
        Ok(())
    }

    /// `out[o] = lut(requant(W·x + b + M(U·h)))`.
    fn eval(
        &self,
        x: &[i8; IN],
        h: &[i8; H],
        lut: &Lut8,
        acc_w: &mut [i32; H],
        acc_u: &mut [i32; H],
        out: &mut [i8; H],
    ) {
        self.w.accumulate(x, acc_w);
        self.u.accumulate(h, acc_u);
        for o in 0..H {
            let acc = acc_w[o].saturating_add(self.u_to_w[o].apply_i32(acc_u[o]));
            out[o] = lut.lookup(self.w.requant()[o].apply(acc));
        }
    }
}

/// Int8 GRU cell (eq. 7). Plain data: [`GruCell::from_parts`] for a model-file decoder,
/// [`GruCell::from_f32`] for the trainer.
#[derive(Debug, Clone, PartialEq)]
pub struct GruCell<const IN: usize, const H: usize> {
    z: Gate<IN, H>,
    r: Gate<IN, H>,
    n: Gate<IN, H>,
    sigmoid: Lut8,
    tanh: Lut8,
}

impl<const IN: usize, const H: usize> GruCell<IN, H> {
    /// The hidden state's fixed scale, 1/127.
    pub const HIDDEN_SCALE: QScale = QScale::UNIT;

    /// A placeholder cell (all zero) to fill in place with [`GruCell::set_in_place`].
    pub const EMPTY: Self = Self {
        z: Gate::EMPTY,
        r: Gate::EMPTY,
        n: Gate::EMPTY,
        sigmoid: Lut8::EMPTY,
        tanh: Lut8::EMPTY,
    };

    /// [`GruCell::from_parts`] in place: `load(g, W_g, U_g)` fills the matrices of
    /// gate `g` (0 = z, 1 = r, 2 = n) where they live, then the cell checks them and
    /// derives its multipliers and tables. No temporary of the cell's size.
    ///
    /// # Errors
    /// The loader's errors; those of [`GruCell::from_parts`]. On error `self` is
    /// partly overwritten.
    pub fn set_in_place(
        &mut self,
        mut load: impl FnMut(usize, &mut QLinear<IN, H>, &mut QLinear<H, H>) -> Result<()>,
    ) -> Result<()> {
        load(0, &mut self.z.w, &mut self.z.u)?;
        load(1, &mut self.r.w, &mut self.r.u)?;
        load(2, &mut self.n.w, &mut self.n.u)?;
        let s = self.z.w.input_scale();
        if s != self.r.w.input_scale() || s != self.n.w.input_scale() {
            return Err(Error::InvalidParameter(
                "GRU gates must share the input scale",
            ));
        }
        self.z.derive(SIGMOID_GATE_INPUT_SCALE)?;
        self.r.derive(SIGMOID_GATE_INPUT_SCALE)?;
        self.n.derive(TANH_GATE_INPUT_SCALE)?;
        self.sigmoid = Lut8::gate_sigmoid();
        self.tanh = Lut8::gate_tanh();
        Ok(())
    }

    /// Assemble from stored gate matrices `(W_g, U_g)` in the order z, r, n. Each `W_g`
    /// maps the input scale to the gate table's input scale (6/127 for z and r, 3/127
    /// for n) and carries the gate bias; each `U_g` maps 1/127 to the same scale with
    /// zero bias.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for mismatched scales, a `U` bias, differing input
    /// scales or an unrepresentable `U`/`W` ratio.
    pub fn from_parts(
        z: (QLinear<IN, H>, QLinear<H, H>),
        r: (QLinear<IN, H>, QLinear<H, H>),
        n: (QLinear<IN, H>, QLinear<H, H>),
    ) -> Result<Self> {
        if z.0.input_scale() != r.0.input_scale() || z.0.input_scale() != n.0.input_scale() {
            return Err(Error::InvalidParameter(
                "GRU gates must share the input scale",
            ));
        }
        Ok(Self {
            z: Gate::new(z.0, z.1, SIGMOID_GATE_INPUT_SCALE)?,
            r: Gate::new(r.0, r.1, SIGMOID_GATE_INPUT_SCALE)?,
            n: Gate::new(n.0, n.1, TANH_GATE_INPUT_SCALE)?,
            sigmoid: Lut8::gate_sigmoid(),
            tanh: Lut8::gate_tanh(),
        })
    }

    /// Quantize a float cell for inputs at `input_scale`.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN/∞ parameters; the errors of [`QLinear::from_f32`]
    /// and [`GruCell::from_parts`].
    pub fn from_f32(float: &GruCellF32<IN, H>, input_scale: QScale) -> Result<Self> {
        let gate = |w: &LinearF32<IN, H>, u: &[[f32; H]; H], table: QScale| -> Result<_> {
            let wq = QLinear::from_f32(w, input_scale, table)?;
            let uq =
                QLinear::from_f32(&LinearF32 { w: *u, b: [0.0; H] }, Self::HIDDEN_SCALE, table)?;
            Ok((wq, uq))
        };
        Self::from_parts(
            gate(&float.w_z, &float.u_z, SIGMOID_GATE_INPUT_SCALE)?,
            gate(&float.w_r, &float.u_r, SIGMOID_GATE_INPUT_SCALE)?,
            gate(&float.w_n, &float.u_n, TANH_GATE_INPUT_SCALE)?,
        )
    }

    /// One step, integer only: `h ← GRU(x, h)` with `h` at 1/127.
    pub fn step(&self, x: &[i8; IN], h: &mut [i8; H], s: &mut GruScratch<H>) {
        self.z
            .eval(x, h, &self.sigmoid, &mut s.acc_w, &mut s.acc_u, &mut s.z);
        self.r
            .eval(x, h, &self.sigmoid, &mut s.acc_w, &mut s.acc_u, &mut s.r);
        let unit = QMultiplier::INV_127;
        for o in 0..H {
            s.rh[o] = unit.apply(i32::from(s.r[o]) * i32::from(h[o]));
        }
        self.n
            .eval(x, &s.rh, &self.tanh, &mut s.acc_w, &mut s.acc_u, &mut s.n);
        for o in 0..H {
            let z = i32::from(s.z[o]); // 0..=127
            let mix = (127 - z) * i32::from(h[o]) + z * i32::from(s.n[o]);
            h[o] = unit.apply(mix);
        }
    }

    /// Run `xs` in order from the state in `h`.
    pub fn run(&self, xs: &[[i8; IN]], h: &mut [i8; H], s: &mut GruScratch<H>) {
        for x in xs {
            self.step(x, h, s);
        }
    }

    /// The input scale `s_x`.
    pub fn input_scale(&self) -> QScale {
        self.z.w.input_scale()
    }

    /// The gate matrices `(W_g, U_g)` in the order z, r, n.
    pub fn gates(&self) -> [(&QLinear<IN, H>, &QLinear<H, H>); 3] {
        [
            (&self.z.w, &self.z.u),
            (&self.r.w, &self.r.u),
            (&self.n.w, &self.n.u),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quant::qparams::MaxAbs;
    use crate::quant::testkit::{
        kernel_pair_tests, random_matrix, random_vector, uniform, KernelPair, Sample,
    };
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    const IN: usize = 8;
    const H: usize = 16;
    const T: usize = 48;

    fn random_cell(rng: &mut Xoshiro128pp) -> GruCellF32<IN, H> {
        let wa = f64::from(uniform(rng, 0.3, 2.0)) / (IN as f64).sqrt();
        let ua = f64::from(uniform(rng, 0.3, 2.0)) / (H as f64).sqrt();
        let lin = |rng: &mut Xoshiro128pp| LinearF32 {
            w: random_matrix(rng, wa),
            b: random_vector(rng, 0.5),
        };
        GruCellF32 {
            w_z: lin(rng),
            w_r: lin(rng),
            w_n: lin(rng),
            u_z: random_matrix(rng, ua),
            u_r: random_matrix(rng, ua),
            u_n: random_matrix(rng, ua),
        }
    }

    struct Gru;
    impl KernelPair for Gru {
        const NAME: &'static str = "GRU cell over T=48 steps (GruCell vs GruCellF32), IN=8 H=16";
        fn run_case(rng: &mut Xoshiro128pp, out: &mut Vec<Sample>) {
            let float = random_cell(rng);
            let x_amp = f64::from(uniform(rng, 0.5, 3.0));
            let xs: Vec<[f32; IN]> = (0..T).map(|_| random_vector(rng, x_amp)).collect();
            let mut range = MaxAbs::new();
            xs.iter().for_each(|x| range.observe_all(x));
            let s_x = range.scale().unwrap();
            let q = GruCell::from_f32(&float, s_x).unwrap();
            let mut hq = [0i8; H];
            let mut hf = [0f32; H];
            let mut scratch = GruScratch::new();
            let lsb = 1.0 / 127.0;
            for x in &xs {
                let mut xq = [0i8; IN];
                let mut xhat = [0f32; IN];
                crate::quant::qparams::quantize_symmetric(x, s_x, &mut xq).unwrap();
                crate::quant::qparams::dequantize(&xq, s_x, &mut xhat).unwrap();
                q.step(&xq, &mut hq, &mut scratch);
                float.step(&xhat, &mut hf);
                for o in 0..H {
                    out.push(Sample::new(
                        f64::from(hq[o]) * lsb,
                        f64::from(hf[o]),
                        GRU_DRIFT_BOUND,
                        lsb,
                    ));
                }
            }
        }
    }

    kernel_pair_tests! {
        gru_drift_within_bound: Gru, seed 61, cases 400;
    }

    #[test]
    fn drift_does_not_grow() {
        let mut rng = Xoshiro128pp::seed_from_u64(62);
        let (mut early, mut late) = (0f64, 0f64);
        for _ in 0..200 {
            let float = random_cell(&mut rng);
            let s_x = QScale::new(2.0 / 127.0).unwrap();
            let q = GruCell::from_f32(&float, s_x).unwrap();
            let (mut hq, mut hf) = ([0i8; H], [0f32; H]);
            let mut scratch = GruScratch::new();
            for t in 0..T {
                let x: [f32; IN] = random_vector(&mut rng, 2.0);
                let mut xq = [0i8; IN];
                let mut xhat = [0f32; IN];
                crate::quant::qparams::quantize_symmetric(&x, s_x, &mut xq).unwrap();
                crate::quant::qparams::dequantize(&xq, s_x, &mut xhat).unwrap();
                q.step(&xq, &mut hq, &mut scratch);
                float.step(&xhat, &mut hf);
                let err = (0..H)
                    .map(|o| (f64::from(hq[o]) / 127.0 - f64::from(hf[o])).abs())
                    .fold(0.0, f64::max);
                if t < 32 {
                    early = early.max(err);
                } else {
                    late = late.max(err);
                }
            }
        }
        std::println!(
            "[quant] gru drift: max err steps 0..32 = {early:.4}, steps 32..48 = {late:.4}"
        );
        assert!(late <= early + 1.0 / 127.0, "{late} vs {early}");
    }

    #[test]
    fn hidden_state_stays_in_range_and_run_equals_steps() {
        let mut rng = Xoshiro128pp::seed_from_u64(63);
        let mut float = random_cell(&mut rng);
        // Saturating pre-activations: huge weights.
        float.w_n.w = random_matrix(&mut rng, 50.0);
        float.u_z = random_matrix(&mut rng, 30.0);
        let q = GruCell::from_f32(&float, QScale::new(0.05).unwrap()).unwrap();
        let xs: Vec<[i8; IN]> = (0..64)
            .map(|_| core::array::from_fn(|_| (rng.next_u32() % 255) as i8))
            .collect();
        let mut h = [0i8; H];
        let mut s = GruScratch::new();
        for x in &xs {
            q.step(x, &mut h, &mut s);
            assert!(h.iter().all(|&v| (-127..=127).contains(&v)));
        }
        let mut h2 = [0i8; H];
        q.run(&xs, &mut h2, &mut s);
        assert_eq!(h, h2);
    }

    #[test]
    fn from_parts_checks() {
        let mut rng = Xoshiro128pp::seed_from_u64(64);
        let float = random_cell(&mut rng);
        let q = GruCell::from_f32(&float, QScale::new(0.02).unwrap()).unwrap();
        let [z, r, n] = q.gates();
        let rebuilt = GruCell::from_parts(
            (z.0.clone(), z.1.clone()),
            (r.0.clone(), r.1.clone()),
            (n.0.clone(), n.1.clone()),
        )
        .unwrap();
        assert_eq!(rebuilt, q);
        // Swapping the n gate into z's place breaks the scale contract.
        assert!(GruCell::from_parts(
            (n.0.clone(), n.1.clone()),
            (r.0.clone(), r.1.clone()),
            (n.0.clone(), n.1.clone()),
        )
        .is_err());
    }
}
