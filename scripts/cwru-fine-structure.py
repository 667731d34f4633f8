#!/usr/bin/env python3
"""How close can a smooth structural model come to a CWRU record's power spectrum?

    bash scripts/cwru-fine-structure.sh [DATA_DIR]

Issue 32 asks the twin's final PSD error on the twelve records of `twin cwru-report` to
reach a median of 3 dB. The twin's structure is a handful of modes: a smooth transfer.
This script measures what a perfectly smooth model would still miss: for each record's
drive-end channel (first 6 s; the 48 kHz normal record decimated by 4 to 12 kHz), the
Welch PSD the loop compares (4 096 points, half overlap, Hann) from a quarter of the
shaft rate to 4.6 kHz, against the same PSD's own moving mean in dB over ±25 Hz and
±100 Hz (the least-squares smooth curve in dB at that smoothness, the loop's own
measure: the best any smooth transfer could do there). Printed: the RMS of
the dB difference, and the record's half-to-half scatter (the two halves' PSDs, same
settings).

Measured 2026-11-27: against its own ±25 Hz smooth curve a record's spectrum is
3.95–6.21 dB away (median 5.0), against the ±100 Hz curve (the smoothness of a few
modes) 5.1–7.8 dB (median 6.4), with its halves 1.5–4.2 dB apart. The loop ends at
5.2–7.6 dB (median 6.0, `docs/closed-loop-cwru.md`): about what a smooth structure
allows. No number of smooth modes reaches a 3 dB median; the fine structure — the
combs of shaft orders and defect teeth, their sidebands and the valleys between them,
their levels and widths — must be modelled line by line.
"""
import csv
import sys

import numpy as np
import scipy.io
import scipy.signal as ss

RECORDS = ["105", "118", "130", "169", "185", "197", "209", "222", "234", "236", "237", "97"]
N = 4096


def load(root, r):
    m = scipy.io.loadmat(root + "/" + r["file"])
    key = [v for v in r["variables"].split(",") if v.endswith("DE_time")][0]
    x = m[key].ravel().astype(float)
    fs = int(r["fs_hz"])
    if fs == 48000:
        x = ss.decimate(x, 4, ftype="fir")
        fs = 12000
    return x[: 6 * fs], fs


def psd(x, fs):
    return ss.welch(x, fs, nperseg=N, noverlap=N // 2)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/cwru"
    rows = list(csv.DictReader(open(root + "/MANIFEST.tsv"), delimiter="\t"))
    print("record label     vs ±25 Hz  vs ±100 Hz  half-to-half  (RMS dB)")
    for r in sorted(rows, key=lambda r: RECORDS.index(r["cwru_file_no"]) if r["cwru_file_no"] in RECORDS else 99):
        if r["cwru_file_no"] not in RECORDS:
            continue
        x, fs = load(root, r)
        shaft = float(r["rpm_recorded"]) / 60.0
        f, p = psd(x, fs)
        sel = (f >= 0.25 * shaft) & (f <= 4600.0)
        db = 10 * np.log10(p)
        out = []
        for half_hz in (25.0, 100.0):
            hw = int(round(half_hz / (fs / N)))
            smooth = np.convolve(db, np.ones(2 * hw + 1) / (2 * hw + 1), mode="same")
            out.append(np.sqrt(np.mean((db[sel] - smooth[sel]) ** 2)))
        h = len(x) // 2
        _, p1 = psd(x[:h], fs)
        _, p2 = psd(x[h:], fs)
        hh = np.sqrt(np.mean((10 * np.log10(p1[sel] / p2[sel])) ** 2))
        print(f"{r['cwru_file_no']:>6} {r['cwru_label']:<10} {out[0]:8.2f} {out[1]:11.2f} {hh:13.2f}")


if __name__ == "__main__":
    main()
