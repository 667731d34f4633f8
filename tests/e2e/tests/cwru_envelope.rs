//! On measured data: the envelope spectrum of CWRU 105.mat (inner race 0.007", 0 HP)
//! peaks at BPFI and that of 130.mat (outer race 0.007" @6:00, 0 HP) at BPFO, within
//! 1 %, with the defect frequencies computed by the core from the 6205 geometry and
//! the recorded shaft speed. The search range 40–400 Hz holds the shaft harmonics
//! above 1×, BPFO, BPFI, 2·BSF and their second harmonics, so the test can fail.

use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::features::{envelope_spectrum, peak_frequency, EnvelopeBand};
use pumptwin_core::fft::Complex32;
use pumptwin_data::record::load_recording;

/// Welch-averaged envelope spectrum of the DE channel over 16384-sample blocks.
fn de_envelope_peak(file: &str) -> Option<(f32, f32)> {
    let dir = pumptwin_e2e::cwru_dir()?;
    let rec = load_recording(&dir.join(file), None, None).expect("record loads");
    let rpm = rec.rpm.expect("CWRU records carry rpm");
    let x = &rec.channel("DE").expect("DE channel").samples;
    const N: usize = 16384;
    let mut scratch = vec![Complex32::ZERO; N];
    let mut env = vec![0.0f32; N];
    let mut block = vec![0.0f32; N / 2 + 1];
    let mut avg = vec![0.0f32; N / 2 + 1];
    let mut blocks = 0;
    for start in (0..x.len().saturating_sub(N)).step_by(N / 2) {
        envelope_spectrum(
            &x[start..start + N],
            rec.fs_hz,
            EnvelopeBand::DEFAULT,
            &mut scratch,
            &mut env,
            &mut block,
        )
        .expect("finite data");
        avg.iter_mut().zip(&block).for_each(|(a, b)| *a += b);
        blocks += 1;
    }
    assert!(blocks >= 10, "a 10 s record gives at least 10 blocks");
    let peak = peak_frequency(&avg, rec.fs_hz, 40.0, 400.0).expect("range");
    Some((peak, rpm / 60.0))
}

#[test]
fn inner_race_105_peaks_at_bpfi() {
    let Some((peak, shaft)) = de_envelope_peak("12k_DE/105.mat") else {
        return;
    };
    let f = BearingGeometry::CWRU_6205_DE.frequencies(shaft);
    assert!(
        (peak / f.bpfi - 1.0).abs() < 0.01,
        "peak {peak} Hz, BPFI {} Hz",
        f.bpfi
    );
}

#[test]
fn outer_race_130_peaks_at_bpfo() {
    let Some((peak, shaft)) = de_envelope_peak("12k_DE/130.mat") else {
        return;
    };
    let f = BearingGeometry::CWRU_6205_DE.frequencies(shaft);
    assert!(
        (peak / f.bpfo - 1.0).abs() < 0.01,
        "peak {peak} Hz, BPFO {} Hz",
        f.bpfo
    );
}
