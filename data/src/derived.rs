//! The paper's derived "temperature" and "pressure" nodes (section 6.2), an option of the
//! trainer (`--nodes derived`), float only and reported apart from the measured-node
//! results.
//!
//! CWRU holds vibration only. The paper builds two further modalities from it:
//! temperature "from the energy envelope of the vibration signal … mapped to thermal
//! changes … after normalization and smoothing filtering", and pressure "by equivalent
//! conversion of the vibration signal's low-frequency components and impact envelope …
//! through band-pass filtering". Here, from the drive-end signal `x` at rate `fs`:
//!
//! ```text
//! TEMP[n] = q[n],   q[n] = q[n−1] + a_T·(x[n]² − q[n−1]),   a_T = 1 − e^(−1/(τ_T·fs))
//!           (a first-order thermal lag of the instantaneous vibration power: a body
//!            heated by the dissipated power with time constant τ_T)
//! PRES[n] = lp_P(x)[n] + lp_P(|x − lp_H(x)|)[n]
//!           (the low-frequency part of the vibration plus the envelope of its
//!            high-frequency part, the impacts; lp_f = one-pole low-pass at f)
//! ```
//!
//! with τ_T = [`THERMAL_TAU_S`], `P` = [`PRESSURE_LOWPASS_HZ`], `H` = [`IMPACT_HIGHPASS_HZ`].
//! Each filter starts from the mean of its input over the first `τ` of the signal so a
//! window carries no start-up transient.
//!
//! Physically these are **not** new measurements: they are deterministic functions of
//! the DE channel and carry no information the DE node lacks (a real pump's
//! temperature, with minutes of thermal inertia, would be constant over a 0.17 s
//! window). The option exists to reproduce the paper's five-node layout and to measure
//! what it changes; the measured three-node model is the product. To keep the split
//! honest the nodes are derived **per window**, from that window's samples only (after
//! the evaluation noise, when there is noise): a filter run over the whole record would
//! carry training-side samples into the first test window through its state.
//!
//! A window whose DE channel is absent has no derived nodes (masked and counted as a
//! missing channel, as any absent sensor). Everything downstream treats them as nodes
//! like any other: features, graphs, node dropout, the indicator targets of eq. 13
//! (their "adjacent-node energy difference" then compares DE with the mean RMS of all
//! other present nodes, the derived ones included).

use crate::recording::{Channel, Recording};

/// Name of the derived temperature node.
pub const TEMP: &str = "TEMP";
/// Name of the derived pressure node.
pub const PRES: &str = "PRES";
/// The channel both are derived from.
pub const SOURCE: &str = "DE";
/// Time constant of the thermal lag, s: short enough that the node still moves across
/// the window's eight 21 ms steps, long enough to smooth single impacts.
pub const THERMAL_TAU_S: f32 = 0.005;
/// Corner of the low-pass giving the pressure node's slow part and the impact envelope, Hz.
pub const PRESSURE_LOWPASS_HZ: f32 = 500.0;
/// Corner of the high-pass isolating the impacts before the envelope, Hz.
pub const IMPACT_HIGHPASS_HZ: f32 = 1_000.0;

/// Whether a node name is one of the derived nodes.
pub fn is_derived(name: &str) -> bool {
    name == TEMP || name == PRES
}

/// Whether a node layout has any derived node (its windows then need
/// [`append_channels`]).
pub fn any_derived(nodes: &[&str]) -> bool {
    nodes.iter().any(|n| is_derived(n))
}

/// One-pole low-pass with its state started at the mean of the first `1/(2π·fc)`
/// seconds of the input.
fn lowpass(x: &[f32], fs_hz: f32, corner_hz: f32) -> Vec<f32> {
    let tau = 1.0 / (2.0 * std::f32::consts::PI * corner_hz);
    first_order(x, fs_hz, tau)
}

/// `y[n] = y[n−1] + a·(x[n] − y[n−1])`, `a = 1 − e^(−1/(τ·fs))`, `y[−1]` = mean of
/// the first `τ·fs` samples (at least one).
fn first_order(x: &[f32], fs_hz: f32, tau_s: f32) -> Vec<f32> {
    let a = 1.0 - (-1.0 / (tau_s * fs_hz)).exp();
    let head = ((tau_s * fs_hz).ceil() as usize).clamp(1, x.len().max(1));
    let mut y = if x.is_empty() {
        0.0
    } else {
        x[..head].iter().map(|v| f64::from(*v)).sum::<f64>() as f32 / head as f32
    };
    x.iter()
        .map(|&v| {
            y += a * (v - y);
            y
        })
        .collect()
}

/// The temperature and pressure signals derived from `x` (one window, or a whole
/// simulated record) at `fs_hz`, see the module docs.
pub fn derive(x: &[f32], fs_hz: f32) -> (Vec<f32>, Vec<f32>) {
    let power: Vec<f32> = x.iter().map(|v| v * v).collect();
    let temp = first_order(&power, fs_hz, THERMAL_TAU_S);
    let slow = lowpass(x, fs_hz, PRESSURE_LOWPASS_HZ);
    let low_h = lowpass(x, fs_hz, IMPACT_HIGHPASS_HZ);
    let impacts: Vec<f32> = x.iter().zip(&low_h).map(|(v, l)| (v - l).abs()).collect();
    let envelope = lowpass(&impacts, fs_hz, PRESSURE_LOWPASS_HZ);
    let pres = slow.iter().zip(&envelope).map(|(s, e)| s + e).collect();
    (temp, pres)
}

/// Append the derived channels to `rec`, computed block by block over consecutive
/// `block` samples of its source channel (a block = one window laid end to end in a
/// scratch recording; `rec.len()` for a whole record). Does nothing when the source
/// channel is absent (the derived nodes are then masked as missing).
pub fn append_channels(rec: &mut Recording, block: usize) {
    let Some(src) = rec.channel(SOURCE) else {
        return;
    };
    let block = block.max(1);
    let mut temp = Vec::with_capacity(src.samples.len());
    let mut pres = Vec::with_capacity(src.samples.len());
    for chunk in src.samples.chunks(block) {
        let (t, p) = derive(chunk, rec.fs_hz);
        temp.extend(t);
        pres.extend(p);
    }
    rec.channels.push(Channel {
        name: TEMP.into(),
        samples: temp,
    });
    rec.channels.push(Channel {
        name: PRES.into(),
        samples: pres,
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temperature_tracks_the_vibration_power_with_a_lag() {
        let fs = 12_000.0;
        // A tone whose amplitude doubles half-way: power 0.5 → 2.0.
        let x: Vec<f32> = (0..2048)
            .map(|n| {
                let a = if n < 1024 { 1.0 } else { 2.0 };
                a * (2.0 * std::f32::consts::PI * 1_500.0 * n as f32 / fs).sin()
            })
            .collect();
        let (temp, pres) = derive(&x, fs);
        assert_eq!(temp.len(), x.len());
        assert_eq!(pres.len(), x.len());
        assert!(temp.iter().all(|t| *t >= 0.0));
        let before = temp[900..1000].iter().sum::<f32>() / 100.0;
        let after = temp[1900..2000].iter().sum::<f32>() / 100.0;
        assert!((before - 0.5).abs() < 0.05, "before {before}");
        assert!((after - 2.0).abs() < 0.2, "after {after}");
        // The lag: one sample after the step the temperature has barely moved.
        assert!(temp[1025] < 0.7, "{}", temp[1025]);
    }

    #[test]
    fn pressure_keeps_slow_motion_and_the_impact_envelope() {
        let fs = 12_000.0;
        // A 50 Hz component plus impacts (3 kHz bursts every 100 samples).
        let x: Vec<f32> = (0..2048)
            .map(|n| {
                let slow = 0.5 * (2.0 * std::f32::consts::PI * 50.0 * n as f32 / fs).sin();
                let burst = if n % 100 < 10 {
                    (2.0 * std::f32::consts::PI * 3_000.0 * n as f32 / fs).sin()
                } else {
                    0.0
                };
                slow + burst
            })
            .collect();
        let (_, pres) = derive(&x, fs);
        let slow_only: Vec<f32> = (0..2048)
            .map(|n| 0.5 * (2.0 * std::f32::consts::PI * 50.0 * n as f32 / fs).sin())
            .collect();
        let (_, pres_slow) = derive(&slow_only, fs);
        // The impacts raise the pressure node's mean (their envelope is positive) …
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
        assert!(mean(&pres) > mean(&pres_slow) + 0.05);
        // … and the slow part passes: the node follows the 50 Hz swing.
        let (lo, hi) = pres_slow
            .iter()
            .fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(hi - lo > 0.8, "swing {}", hi - lo);
    }

    #[test]
    fn channels_are_derived_per_block_and_absent_without_the_source() {
        let x: Vec<f32> = (0..4096)
            .map(|n| ((n * 7919) % 97) as f32 / 97.0 - 0.5)
            .collect();
        let mut rec = Recording {
            name: "r".into(),
            fs_hz: 12_000.0,
            rpm: None,
            channels: vec![Channel {
                name: SOURCE.into(),
                samples: x.clone(),
            }],
        };
        append_channels(&mut rec, 2048);
        let temp = &rec.channel(TEMP).unwrap().samples;
        // The second block is derived from its own samples only.
        let (t2, _) = derive(&x[2048..], 12_000.0);
        assert_eq!(&temp[2048..], t2.as_slice());
        let mut no_de = Recording {
            channels: vec![Channel {
                name: "FE".into(),
                samples: x,
            }],
            ..rec
        };
        append_channels(&mut no_de, 2048);
        assert!(no_de.channel(TEMP).is_none());
    }
}
