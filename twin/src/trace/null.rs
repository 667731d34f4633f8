//! What a statistic reads when the model is the whole truth: the current model
//! simulated again with other seeds (a parametric bootstrap of the fitted model,
//! Efron & Tibshirani 1993, ch. 6), so that a tracer's threshold comes from the record
//! it reads rather than from a constant.
//!
//! A statistic `T(y)` of a record `y` against the model's simulation (a kurtosis ratio,
//! the dilution of the defect's rhythm in a band, a ring-down's frequency shift) has a
//! scatter that depends on the record: a bearing whose impacts vary widely in strength
//! has a kurtosis that differs by 30 % from one six-second stretch to the next, a
//! healthy one by 2 %. Under "the model explains the record", the measured `T(x)` is
//! one more draw of `T` over the model's own realizations `y_k`; the evidence is how
//! far it lies above them, `z = (T(x) − mean_k T(y_k)) / sd_k T(y_k)`, and a tracer
//! offers its effect only when `z ≥ NULL_Z` as well as above the statistic's physical
//! minimum. The report gives `z` and the one-sided Gaussian p-value with each claim.

use crate::twin::TwinModel;
use std::cell::OnceCell;

/// Realizations of the model drawn for the null. Eight: the standard deviation of
/// eight draws is within ±25 % of the true one (one standard error, Gaussian), and the
/// eight simulations cost a few percent of a loop's evaluations; drawn only when a
/// tracer first asks.
pub const NULL_DRAWS: usize = 8;

/// Least `z` of a statistic over its null for the tracer to offer its effect: 3, a
/// one-sided p of 0.0013 (Gaussian) and of about 0.01 with the spread estimated from
/// [`NULL_DRAWS`] draws (Student's t, 7 degrees of freedom); a record meets some
/// five such tests, so a control passes them all in about 95 cases of 100.
pub const NULL_Z: f32 = 3.0;

/// The current model's realizations under other seeds, drawn on first use.
#[derive(Debug)]
pub struct NullDraws<'a> {
    model: &'a TwinModel,
    n: usize,
    seed: u64,
    draws: OnceCell<Vec<Vec<f32>>>,
}

/// Draws kept from one round to the next while the model stays the same (a round that
/// keeps nothing leaves the next one the same model): the parameters they were drawn
/// for, and the draws.
pub type KeptDraws = Option<(Vec<f64>, Vec<Vec<f32>>)>;

impl<'a> NullDraws<'a> {
    /// Draws of `model`, `n` samples each, with seeds derived from `seed` (which must
    /// differ from the one the compared simulation used); `kept`'s draws are used
    /// where they were drawn for the same parameters.
    pub fn new(model: &'a TwinModel, n: usize, seed: u64, kept: KeptDraws) -> Self {
        let draws = OnceCell::new();
        if let Some((theta, d)) = kept {
            if theta == model.theta() && d.iter().all(|y| y.len() == n) {
                let _ = draws.set(d);
            }
        }
        Self {
            model,
            n,
            seed,
            draws,
        }
    }

    /// The draws made, to keep for the next round.
    pub fn keep(self) -> KeptDraws {
        let theta = self.model.theta();
        self.draws.into_inner().map(|d| (theta, d))
    }

    /// The draws (a draw the model cannot render is left out: the test then has
    /// fewer, and with fewer than two it says nothing is significant).
    pub fn draws(&self) -> &[Vec<f32>] {
        self.draws.get_or_init(|| {
            (0..NULL_DRAWS as u64)
                .filter_map(|k| {
                    let seed = self.seed ^ (0x9E37_79B9_7F4A_7C15u64.wrapping_mul(k + 1));
                    self.model.render(self.n, seed).ok()
                })
                .collect()
        })
    }

    /// The statistic `stat` of the record (`observed`) against its values over the
    /// draws; a draw where `stat` has no value is left out.
    pub fn test(&self, observed: f32, stat: impl Fn(&[f32]) -> Option<f32>) -> NullTest {
        let values: Vec<f64> = self
            .draws()
            .iter()
            .filter_map(|y| stat(y))
            .filter(|v| v.is_finite())
            .map(f64::from)
            .collect();
        NullTest::of(observed, &values)
    }
}

/// A statistic against its null.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NullTest {
    /// The record's value.
    pub observed: f32,
    /// Mean over the draws.
    pub mean: f32,
    /// Standard deviation over the draws (n − 1), or the wider spread it was
    /// [`widened`](Self::widened) to.
    pub sd: f32,
    /// Draws it was read over.
    pub draws: usize,
}

impl NullTest {
    /// `observed` against `values`.
    pub fn of(observed: f32, values: &[f64]) -> Self {
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n.max(1) as f64;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64;
        Self {
            observed,
            mean: mean as f32,
            sd: var.sqrt() as f32,
            draws: n,
        }
    }

    /// How many of the null's standard deviations the record lies above its mean
    /// (the spread floored at a millionth of the scale, so identical draws give a
    /// finite `z`); `-inf` with fewer than two draws.
    pub fn z(&self) -> f32 {
        if self.draws < 2 {
            return f32::NEG_INFINITY;
        }
        let floor = 1e-6 * (self.mean.abs() + self.observed.abs()).max(1e-12);
        (self.observed - self.mean) / self.sd.max(floor)
    }

    /// Whether the record lies [`NULL_Z`] or more above the null.
    pub fn significant(&self) -> bool {
        self.z() >= NULL_Z
    }

    /// The test with the null's spread no narrower than `sd`: a statistic whose own
    /// standard error, read off the record, is wider than the draws' spread scatters
    /// that much under the null as well (the record holds something the model's draws
    /// lack, and the draws alone would call its noise significant).
    pub fn widened(self, sd: f32) -> Self {
        Self {
            sd: self.sd.max(sd),
            ..self
        }
    }

    /// The one-sided Gaussian p-value of `z`.
    pub fn p_value(&self) -> f64 {
        upper_tail(f64::from(self.z()))
    }

    /// The test as a claim's evidence figures, under `name`.
    pub fn figures(&self, name: &str) -> serde_json::Value {
        serde_json::json!({
            "statistic": name,
            "observed": self.observed,
            "null_mean": self.mean,
            "null_sd": self.sd,
            "null_draws": self.draws,
            "z": self.z(),
            "p_value": self.p_value(),
        })
    }
}

/// `P(Z > z)` for a standard normal `Z` (Abramowitz & Stegun 7.1.26 for erfc, error
/// under 1.5e-7).
fn upper_tail(z: f64) -> f64 {
    if z.is_nan() {
        return 1.0;
    }
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erfc = poly * (-x * x).exp();
    if z >= 0.0 {
        0.5 * erfc
    } else {
        1.0 - 0.5 * erfc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gaussian_tail_is_right() {
        for (z, p) in [
            (0.0, 0.5),
            (1.0, 0.158_655),
            (3.0, 0.001_35),
            (-2.0, 0.977_25),
        ] {
            assert!((upper_tail(z) - p).abs() < 2e-6, "{z}: {}", upper_tail(z));
        }
        assert_eq!(upper_tail(f64::NAN), 1.0);
        assert!(upper_tail(f64::INFINITY) < 1e-300);
    }

    #[test]
    fn z_reads_the_spread_of_the_draws() {
        let t = NullTest::of(4.0, &[0.0, 1.0, -1.0, 0.0]);
        assert!((t.sd - (2.0f32 / 3.0).sqrt()).abs() < 1e-6);
        assert!(t.significant() && (t.z() - 4.0 / t.sd).abs() < 1e-4);
        assert!(!NullTest::of(0.5, &[0.0, 1.0, -1.0, 0.0]).significant());
        // Too few draws to say anything; identical draws still give a finite z.
        assert!(!NullTest::of(9.0, &[0.0]).significant());
        assert!(NullTest::of(1.0, &[0.5, 0.5, 0.5]).z().is_finite());
        // Widened to a wider spread it reads in that spread; a narrower one, or NaN,
        // leaves it as it was.
        assert!((t.widened(2.0).z() - 2.0).abs() < 1e-6);
        assert!(!t.widened(2.0).significant());
        assert_eq!(t.widened(0.1), t);
        assert_eq!(t.widened(f32::NAN), t);
    }
}
