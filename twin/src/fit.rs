//! Fitting Θ to a measured signature: eq. 10 (`Θ ← Θ − η ∂L_phy/∂Θ`) realized as
//! Levenberg–Marquardt, the damped Gauss–Newton form of the same gradient step, on the
//! residual vector of [`super::signature::residual_vector`]. The Jacobian is taken by
//! forward differences with common random numbers (one fixed PRNG seed for every
//! evaluation), so the loss is a smooth function of Θ even though the model has random
//! excitation.

use super::signature::{
    error_figures, residual_vector, to_db, ErrorFigures, Signature, SignatureConfig, SignatureError,
};
use super::twin::TwinModel;

/// What a fit compares against.
#[derive(Debug, Clone)]
pub struct Target {
    /// Measured signature.
    pub meas: Signature,
    /// Its PSD in dB.
    pub psd_db: Vec<f32>,
    /// Its envelope spectrum in dB.
    pub env_db: Vec<f32>,
    /// Signature settings.
    pub cfg: SignatureConfig,
}

impl Target {
    /// The fit's cost of a simulated signature against this target: Σ r² of
    /// [`residual_vector`].
    pub fn cost(&self, sim: &Signature) -> f32 {
        residual_vector(sim, &self.psd_db, &self.env_db, &self.meas, &self.cfg)
            .iter()
            .map(|v| v * v)
            .sum()
    }

    /// Signature of a measured signal.
    pub fn of(x: &[f32], cfg: SignatureConfig) -> Result<Self, SignatureError> {
        let meas = Signature::of(x, &cfg)?;
        let psd_db = to_db(&meas.psd, &meas.psd);
        let env_db = to_db(&meas.env, &meas.env);
        Ok(Self {
            meas,
            psd_db,
            env_db,
            cfg,
        })
    }
}

/// Settings of one fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitConfig {
    /// Samples simulated per evaluation.
    pub n_sim: usize,
    /// PRNG seed shared by all evaluations (common random numbers).
    pub seed: u64,
    /// Levenberg–Marquardt iterations at most.
    pub max_iter: usize,
    /// Relative cost gain below which an iteration ends the fit.
    pub min_gain: f32,
    /// Model evaluations after which no further iteration starts (the fit ends where
    /// it stands; one iteration may overrun it by its Jacobian and line search).
    pub max_evaluations: usize,
}

/// A fitted model and how well it fits.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// The model at the optimum.
    pub model: TwinModel,
    /// [`super::signature::total_error`] at the optimum (= Σ r²).
    pub cost: f32,
    /// Error figures at the optimum.
    pub figures: ErrorFigures,
    /// Model evaluations spent.
    pub evaluations: usize,
}

/// Errors of a fit.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// Simulation failed.
    #[error("simulation: {0}")]
    Core(#[from] pumptwin_core::Error),
    /// Signature failed.
    #[error("signature: {0}")]
    Signature(#[from] SignatureError),
}

/// Simulate `model` and compare: `(residual vector, cost, signature)`.
pub fn evaluate(
    model: &TwinModel,
    target: &Target,
    cfg: &FitConfig,
) -> Result<(Vec<f32>, f32, Signature), FitError> {
    let y = model.render(cfg.n_sim, cfg.seed)?;
    let sig = Signature::of(&y, &target.cfg)?;
    let r = residual_vector(
        &sig,
        &target.psd_db,
        &target.env_db,
        &target.meas,
        &target.cfg,
    );
    let cost = r.iter().map(|v| v * v).sum();
    Ok((r, cost, sig))
}

/// Solve the symmetric positive definite system `a·x = b` (Cholesky); `None` if singular.
fn solve_spd(a: &[Vec<f64>], b: &[f64]) -> Option<Vec<f64>> {
    let n = b.len();
    let mut l = vec![vec![0.0f64; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = a[i][i] - s;
                if d <= 0.0 || !d.is_finite() {
                    return None;
                }
                l[i][j] = d.sqrt();
            } else {
                l[i][j] = (a[i][j] - s) / l[j][j];
            }
        }
    }
    let mut y = vec![0.0f64; n];
    for i in 0..n {
        y[i] = (b[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
    }
    let mut x = vec![0.0f64; n];
    for i in (0..n).rev() {
        x[i] = (y[i] - ((i + 1)..n).map(|k| l[k][i] * x[k]).sum::<f64>()) / l[i][i];
    }
    Some(x)
}

/// The Gauss–Newton normal equations of the Jacobian's columns `jac` (one per free
/// parameter) and the residual `r`: `(JᵀJ, −Jᵀr)`.
pub(crate) fn normal_equations<R: Copy + Into<f64>>(
    jac: &[Vec<f64>],
    r: &[R],
) -> (Vec<Vec<f64>>, Vec<f64>) {
    let p = jac.len();
    let mut jtj = vec![vec![0.0f64; p]; p];
    let mut neg_g = vec![0.0f64; p];
    for i in 0..p {
        for j in 0..=i {
            let s: f64 = jac[i].iter().zip(&jac[j]).map(|(a, b)| a * b).sum();
            jtj[i][j] = s;
            jtj[j][i] = s;
        }
        let g: f64 = jac[i].iter().zip(r).map(|(a, b)| a * (*b).into()).sum();
        neg_g[i] = -g;
    }
    (jtj, neg_g)
}

/// The Levenberg–Marquardt step of the normal equations `(jtj, neg_g)` at damping
/// `lambda` (Marquardt's, on the diagonal), shortened so that no parameter moves by
/// more than `max_step`; `None` where the damped system is singular.
pub(crate) fn damped_step(
    jtj: &[Vec<f64>],
    neg_g: &[f64],
    lambda: f64,
    max_step: f64,
) -> Option<Vec<f64>> {
    let mut a = jtj.to_vec();
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += lambda * row[i].max(1e-9) + 1e-12;
    }
    let mut delta = solve_spd(&a, neg_g)?;
    let biggest = delta.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    if biggest > max_step {
        delta.iter_mut().for_each(|d| *d *= max_step / biggest);
    }
    Some(delta)
}

/// Levenberg–Marquardt from `start`.
pub fn fit(start: &TwinModel, target: &Target, cfg: &FitConfig) -> Result<FitResult, FitError> {
    let mut theta = start.theta();
    // Parameters with a zero step are held (the defect rate: it is measured from the
    // comb directly, and the cost is too rough in it for derivatives).
    let free: Vec<usize> = (0..theta.len())
        .filter(|&i| start.params[i].step > 0.0)
        .collect();
    let p = free.len();
    let (mut r, mut cost, _) = evaluate(start, target, cfg)?;
    let mut evaluations = 1;
    let mut lambda = 1e-2f64;
    for _ in 0..cfg.max_iter {
        if evaluations >= cfg.max_evaluations {
            break;
        }
        // Jacobian by forward differences.
        let mut jac = vec![vec![0.0f64; r.len()]; p];
        for (col, &i) in jac.iter_mut().zip(&free) {
            let step = start.params[i].step;
            let mut t = theta.clone();
            t[i] += step;
            let (ri, _, _) = evaluate(&start.with_theta(&t), target, cfg)?;
            evaluations += 1;
            for (c, (a, b)) in col.iter_mut().zip(ri.iter().zip(&r)) {
                *c = f64::from(a - b) / step;
            }
        }
        let (jtj, neg_g) = normal_equations(&jac, &r);
        let mut improved = false;
        for _ in 0..6 {
            // Trust region in unconstrained units: no parameter moves by more than 0.7.
            let Some(delta) = damped_step(&jtj, &neg_g, lambda, 0.7) else {
                lambda *= 4.0;
                continue;
            };
            let mut trial = theta.clone();
            for (&i, d) in free.iter().zip(&delta) {
                trial[i] += d;
            }
            let candidate = start.with_theta(&trial);
            let outcome = evaluate(&candidate, target, cfg);
            evaluations += 1;
            match outcome {
                Ok((rt, ct, _)) if ct < cost => {
                    let gain = (cost - ct) / cost.max(1e-12);
                    theta = trial;
                    r = rt;
                    cost = ct;
                    lambda = (lambda / 3.0).max(1e-7);
                    improved = gain > cfg.min_gain;
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        if !improved {
            break;
        }
    }
    let model = start.with_theta(&theta);
    let (_, _, sig) = evaluate(&model, target, cfg)?;
    let figures = error_figures(&sig, &target.meas, &target.cfg);
    Ok(FitResult {
        model,
        cost,
        figures,
        evaluations: evaluations + 1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves() {
        let a = vec![vec![4.0, 2.0], vec![2.0, 3.0]];
        let x = solve_spd(&a, &[2.0, 1.0]).unwrap();
        assert!((4.0 * x[0] + 2.0 * x[1] - 2.0).abs() < 1e-12);
        assert!((2.0 * x[0] + 3.0 * x[1] - 1.0).abs() < 1e-12);
        assert!(solve_spd(&[vec![0.0]], &[1.0]).is_none());
    }
}
