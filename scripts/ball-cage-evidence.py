#!/usr/bin/env python3
"""Does a CWRU drive-end ball fault show its cage? The hypothesis of issue 31 after the
2·BSF family was found absent (core::diagnosis): a spalled ball strikes a race only
while the spot faces it and its load passes through the load zone once per cage turn,
so its impacts may be modulated at the cage rate (FTF) even when their own rhythm is
lost — an envelope line at FTF and its harmonics, or sidebands at 2·BSF ± FTF.

    bash scripts/ball-cage-evidence.sh [DATA_DIR] [LABEL_PREFIX ...]

Per record: 8 192-sample stretches (half overlap) of the DE channel at 12 kHz (the
48 kHz normal record decimated by 4), the most impulsive band (spectral kurtosis of the
analytic signal over bands 1.2/1.5/2 kHz wide from 500 Hz to 5 kHz, third-width steps),
the Hann envelope spectrum there, and each family's level: the mean over its members
of the highest bin within ±2 % (at least one bin) over the median of the envelope
spectrum between 0.2× shaft and 4·BPFI. Printed: the median over the stretches of SK
and of the levels of FTF (1–3×), 2·BSF (2×, 4× BSF), 2·BSF ± FTF, BPFO (1–2×),
BPFI (1–2×), shaft (1–2×).

Measured 2026-11-27 on the development records (0.007" and 0.021" and the normal
record; the 0.014" ones are held out and were not run): FTF 4.2–12.6 dB on the ball
records, 2.9–14.5 dB on the race records, 6.4 dB on the normal one; 2·BSF ± FTF
5.5–14.4 dB (ball) against 1.5–15.2 dB (race). Neither separates the ball records
from the others: the hypothesis is not supported.
"""
import csv
import sys

import numpy as np
import scipy.io
import scipy.signal

N = 8192


def load(root, r):
    m = scipy.io.loadmat(root + "/" + r["file"])
    key = [v for v in r["variables"].split(",") if v.endswith("DE_time")][0]
    x = m[key].ravel().astype(float)
    fs = int(r["fs_hz"])
    if fs == 48000:
        x, fs = scipy.signal.resample_poly(x, 1, 4), 12000
    return x, fs


def sk_band(X, fs):
    f = np.fft.rfftfreq(N, 1 / fs)
    best = None
    for width in (1200, 1500, 2000):
        lo = 500.0
        while lo + width <= 5000:
            band = (f >= lo) & (f < lo + width)
            Z = np.zeros(N, complex)
            Z[: len(f)][band] = 2 * X[band]
            z = np.fft.ifft(Z)
            p = np.abs(z) ** 2
            sk = np.mean(p**2) / np.mean(p) ** 2 - 2
            if best is None or sk > best[0]:
                best = (sk, z)
            lo += width / 3
    return best


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/cwru"
    prefixes = sys.argv[2:] or ["B007", "B021", "IR007", "IR021", "OR007", "OR021", "Normal"]
    n, d, pitch = 9, 0.3126, 1.537
    ftf = 0.5 * (1 - d / pitch)
    bsf = pitch / (2 * d) * (1 - (d / pitch) ** 2)
    bpfo, bpfi = n * ftf, n * (1 - ftf)
    fams = {
        "FTF": [ftf, 2 * ftf, 3 * ftf],
        "2BSF": [2 * bsf, 4 * bsf],
        "2BSF±FTF": [2 * bsf - ftf, 2 * bsf + ftf],
        "BPFO": [bpfo, 2 * bpfo],
        "BPFI": [bpfi, 2 * bpfi],
        "shaft": [1, 2],
    }
    for r in csv.DictReader(open(root + "/MANIFEST.tsv"), delimiter="\t"):
        label = r["cwru_label"]
        if not any(label.startswith(p) for p in prefixes):
            continue
        x, fs = load(root, r)
        shaft = float(r["rpm_recorded"] or r["rpm_nominal"]) / 60
        fr = np.fft.rfftfreq(N, 1 / fs)
        rows = []
        for s in range(0, len(x) - N, N // 2):
            w = x[s : s + N] - x[s : s + N].mean()
            sk, z = sk_band(np.fft.rfft(w), fs)
            e = np.abs(z)
            es = np.abs(np.fft.rfft((e - e.mean()) * np.hanning(N))) ** 2
            med = np.median(es[(fr > 0.2 * shaft) & (fr < 4 * bpfi * shaft)])

            def level(orders):
                out = []
                for o in orders:
                    c = o * shaft
                    i = np.where(np.abs(fr - c) <= max(0.02 * c, fr[1]))[0]
                    out.append(10 * np.log10(es[i].max() / med))
                return np.mean(out)

            rows.append([sk] + [level(v) for v in fams.values()])
        a = np.median(np.array(rows), axis=0)
        print(f"{label:12s} stretches {len(rows):3d} SK {a[0]:5.2f} "
              + " ".join(f"{k} {v:5.1f}" for k, v in zip(fams, a[1:])))


if __name__ == "__main__":
    main()
