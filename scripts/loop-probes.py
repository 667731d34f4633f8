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

Then `pumptwin twin loop --input OUT_DIR/<name>.csv --out OUT_DIR/<name>`; the figures
of the fourteenth session's note are each report.json's `steps`, `error_initial` and
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


if __name__ == "__main__":
    main()
