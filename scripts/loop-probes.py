#!/usr/bin/env python3
"""Records for probing `pumptwin twin loop` beyond the e2e tests: other rates and
lengths, tones beside the defect comb, two tones, noise bands.

    pumptwin twin generate --effect none --seed 41 --duration 4 --out OUT_DIR/none.csv
    .venv-probe/bin/python scripts/loop-probes.py ../shared/data/cwru OUT_DIR

(`bash scripts/linear-probe.sh` makes .venv-probe once.) It writes CSVs that declare
their rate and speed (`# fs_hz=… rpm=…`):

    r209_<fs>_<s>.csv  CWRU 209's drive-end channel (first 6 s) resampled (polyphase)
                       to 20, 25.6, 48, 64 or 8 kHz, 6 s or cut to its first 1 s
    tone_<f>.csv       the generated clean record (none.csv) + a 0.05 g tone at 1500,
                       2150.3 or 3011.7 Hz (beside 14, 20, 28 x BPFO)
    twotone.csv        + 0.05 g at 437.3 Hz and 0.04 g at 1234.5 Hz
    band<lo>.csv       + white noise (0.6 x the record's RMS) through a 3rd-order
                       Butterworth band-pass 900-1300, 1800-2400 or 3800-4400 Hz
    (fifteenth session, effects the generator does not have)
    subsync.csv        + 0.08 g at 0.43 x shaft (a whirl, 12.9 Hz)
    ftf.csv            + 0.06 g at 0.398 x shaft (the cage rate)
    fm.csv             + 0.05 g at 900 Hz, frequency-modulated +-5 Hz at 1 Hz
    am_slow.csv        the clean record amplitude-modulated 50 % at 2.7 Hz
    bursts.csv         + 40 random impulses through a 3.0-3.6 kHz band-pass
    beat.csv           + 0.04 g at 1000 and at 1003 Hz
    mains60.csv        + 60, 120, 180 Hz (0.04, 0.01, 0.02 g)
    clip.csv           clipped at 60 % of its peak
    drift.csv          + 0.05 g offset and a 0.1 g ramp
    (sixteenth session)
    am_<f>_<d>.csv     the clean record amplitude-modulated at f = 1.8, 4.2, 6.1, 9.5 Hz
                       (depth d): a load that swells and fades at no kinematic rate
    rb<n>.csv          + n = 100, 200, 400 random ring-downs (3.3 kHz, 600 Hz wide,
                       random strength): bursts over the structure's band
    (eighteenth session; needs OUT_DIR/lz.csv, an inner-race fault with its load zone:
     pumptwin twin generate --effect load-zone-modulation --seed 1 --duration 4 --out OUT_DIR/lz.csv)
    lz_am<f>.csv       lz.csv amplitude-modulated at f = 2.7 Hz (50 %) or 6.1 Hz (30 %):
                       a pulsating pump load on top of the load zone

Then `pumptwin twin loop --input OUT_DIR/<name>.csv --out OUT_DIR/<name>`; the figures
of the fourteenth to eighteenth sessions' notes are each report.json's `steps`, `error_initial` and
`error_final`.
"""
import sys
from pathlib import Path

import numpy as np
import scipy.io as sio
from scipy.signal import butter, lfilter, resample_poly


def write(path, x, fs, rpm):
    with open(path, "w") as fh:
        fh.write(f"# fs_hz={fs} rpm={rpm}\nDE\n")
        fh.write("\n".join(f"{v:.6f}" for v in x) + "\n")


def main():
    data, out = Path(sys.argv[1]), Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    m = sio.loadmat(data / "12k_DE" / "209.mat")
    x = m[[k for k in m if k.endswith("DE_time")][0]].ravel().astype(float)[: 6 * 12000]
    rpm = float(m[[k for k in m if k.endswith("RPM")][0]].ravel()[0])
    for fs, (up, down) in {25600: (32, 15), 20000: (5, 3), 48000: (4, 1), 8000: (2, 3), 64000: (16, 3)}.items():
        y = resample_poly(x, up, down)
        for seconds in (6, 1):
            write(out / f"r209_{fs}_{seconds}.csv", y[: seconds * fs], fs, rpm)

    clean = np.loadtxt(out / "none.csv", skiprows=2)
    fs, rpm = 12000, 1797
    t = np.arange(len(clean)) / fs
    tone = lambda f, a: a * np.sin(2 * np.pi * f * t)
    for f in (1500.0, 2150.3, 3011.7):
        write(out / f"tone_{int(f)}.csv", clean + tone(f, 0.05), fs, rpm)
    write(out / "twotone.csv", clean + tone(437.3, 0.05) + tone(1234.5, 0.04), fs, rpm)
    rng = np.random.default_rng(5)
    for lo, hi in ((900, 1300), (1800, 2400), (3800, 4400)):
        b, a = butter(3, [lo / (fs / 2), hi / (fs / 2)], btype="band")
        noise = lfilter(b, a, rng.normal(0, 0.6 * clean.std(), len(clean)))
        write(out / f"band{lo}.csv", clean + noise, fs, rpm)

    shaft = rpm / 60.0
    write(out / "subsync.csv", clean + tone(0.43 * shaft, 0.08), fs, rpm)
    write(out / "ftf.csv", clean + tone(0.398 * shaft, 0.06), fs, rpm)
    fm = 0.05 * np.sin(2 * np.pi * 900 * t + 5 * np.sin(2 * np.pi * 1.0 * t))
    write(out / "fm.csv", clean + fm, fs, rpm)
    write(out / "am_slow.csv", clean * (1 + 0.5 * np.sin(2 * np.pi * 2.7 * t)), fs, rpm)
    impulses = np.zeros_like(clean)
    impulses[np.random.default_rng(7).choice(len(clean), 40, replace=False)] = 1.0
    b, a = butter(2, [3000 / (fs / 2), 3600 / (fs / 2)], btype="band")
    write(out / "bursts.csv", clean + 3 * lfilter(b, a, impulses), fs, rpm)
    write(out / "beat.csv", clean + tone(1000, 0.04) + tone(1003, 0.04), fs, rpm)
    write(out / "mains60.csv", clean + tone(60, 0.04) + tone(120, 0.01) + tone(180, 0.02), fs, rpm)
    c = 0.6 * np.abs(clean).max()
    write(out / "clip.csv", np.clip(clean, -c, c), fs, rpm)
    write(out / "drift.csv", clean + 0.05 + 0.1 * t / t[-1], fs, rpm)

    # Sixteenth session: modulation at rates no kinematics name, ring-down bursts.
    for f, d in ((1.8, 0.5), (4.2, 0.2), (6.1, 0.3), (9.5, 0.4)):
        write(out / f"am_{f}_{d}.csv", clean * (1 + d * np.sin(2 * np.pi * f * t)), fs, rpm)
    rng = np.random.default_rng(11)
    tau = 1 / (np.pi * 600)
    h = np.exp(-np.arange(int(8 * tau * fs)) / fs / tau) * np.sin(
        2 * np.pi * 3300 * np.arange(int(8 * tau * fs)) / fs
    )
    for n, a in ((200, 1.0), (100, 1.5), (400, 0.7)):
        y = clean.copy()
        for p in rng.choice(len(clean) - len(h), n, replace=False):
            y[p : p + len(h)] += a * rng.uniform(0.5, 1.5) * h
        write(out / f"rb{n}.csv", y, fs, rpm)

    # Eighteenth session: a pulsating load on an inner-race fault's load zone.
    if (out / "lz.csv").exists():
        lz = np.loadtxt(out / "lz.csv", skiprows=2)
        tl = np.arange(len(lz)) / fs
        for f, d in ((2.7, 0.5), (6.1, 0.3)):
            write(out / f"lz_am{f}.csv", lz * (1 + d * np.sin(2 * np.pi * f * tl)), fs, rpm)


if __name__ == "__main__":
    main()
