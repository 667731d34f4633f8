#!/usr/bin/env python3
"""Is a defect line hidden in a narrow band? The band-selected envelope check of the
fault-size records (docs/evaluation-cwru.md, "Fault-size: what stands between ...").

    bash scripts/linear-probe.sh   # once: makes .venv-probe (numpy, scikit-learn, scipy)
    .venv-probe/bin/python scripts/band-envelope-evidence.py [DATA_DIR] [CHANNEL]
    .venv-probe/bin/python scripts/band-envelope-evidence.py [DATA_DIR] floors

The core demodulates one broad band (500 Hz - 5 kHz). The analyst's standard answer to
a missing envelope line is to demodulate the band where the impacts stand out: the
band of largest envelope kurtosis on a 1/3-binary tree (Antoni's kurtogram), or every
band of the tree in turn. This script does all three per 2048-sample window of each
drive-end fault record (12 kHz, outer race at 6:00; CHANNEL DE or FE, default DE):
the broad band, the 15 bands of the tree's levels 2-4 (375-1500 Hz wide) inside
250 Hz - 5 kHz, the kurtogram's band, and the best band for each line. A line's level
is its peak (+-1 bin) over the median of the envelope spectrum within +-40 Hz of it
(the line's own bins left out): a local baseline, because a narrow band's envelope
spectrum falls off above the band's width and a median over a fixed range would lift
every line in it.

Per record it prints the share of windows whose strongest line (BPFO, BPFI, BSF of the
drive-end 6205 bearing) is the record's own fault type, read in the broad band, in the
kurtogram's band, and as the strongest line over all bands, and the mean over windows
of the strongest level of each line over all bands. With `floors` instead of a channel it weighs the local baseline against the core's
floor (the median of the envelope spectrum up to four times BPFI) in the core's own
reading (broad band, two harmonics, slip tolerance max(1 bin, 1.5 %)): the
strongest-line rule per DE window on the fault-size training side (0.007" + 0.021")
and test side (0.014"). Measured 2026-11-25: training side core floor 82.29 %
(IR 100, B 46.8, OR 100), local 71.77 % (100, 19.3, 96.0); test side 53.81 %
(48.7, 83.1, 29.7) and 58.76 % (98.3, 49.6, 28.4); the local BPFI prominence of
IR014 (median 7.5-8.4 dB per record) is matched by B021's (7.7-9.2; B007 4.2-6.5).

White Gaussian noise reads 9.9 dB on
the mean (7.4-12.6 dB, 10th-90th percentile) as the strongest of 15 bands, and one
type in three by chance.

What it shows (2026-11-25): at DE, OR014 (records 197-200) has no BPFO line in any
band: its best-band levels are 10-14 dB for all three lines, as the ball records', and
its own line wins 17-69 % of the windows (chance: 33 %), against 80-100 % for OR007 and
OR021 in every band choice. IR014 keeps its BPFI line in every choice (68-100 %). No
ball record of any size has a BSF line in any band (best-band BSF 8-11 dB). At FE
a weak BPFO level (13-15 dB best band) appears in OR014 at 1-3 HP, but the ball records
of every size at 2-3 HP reach the same (12-15 dB), so it does not tell OR014 from B014.
"""
import csv
import os
import sys

import numpy as np
import scipy.io as sio

# CWRU drive-end bearing (SKF 6205-2RS JEM) defect orders (multiples of shaft rate),
# as the core's `cwru-6205-de` preset.
ORDERS = {"OR": 3.5848, "IR": 5.4152, "B": 2.3568}
TYPES = list(ORDERS)
WINDOW = 2048
FS = 12000.0


def tree_bands():
    """The broad band, then levels 2-4 of the 1/3-binary tree over 0 - fs/2 inside
    250 Hz - 5 kHz (the common band limit)."""
    bands = [(500.0, 5000.0)]
    for level in (2, 3, 4):
        width = FS / 2 / 2**level
        bands += [(i * width, (i + 1) * width) for i in range(2**level)
                  if i * width >= 250.0 and (i + 1) * width <= 5000.0]
    return bands


BANDS = tree_bands()
FREQ = np.arange(WINDOW) * FS / WINDOW
BIN = np.arange(WINDOW)
MASKS = [(BIN > 0) & (BIN < WINDOW // 2) & (FREQ >= lo) & (FREQ <= hi) for lo, hi in BANDS]
HANN = np.hanning(WINDOW)
DF = FS / WINDOW


def line_levels(x, shaft_hz):
    """[band, type] line levels in dB over the local baseline, and [band] envelope
    kurtosis, of one window."""
    spectrum = np.fft.fft(x - x.mean())
    levels = np.zeros((len(BANDS), len(TYPES)))
    kurt = np.zeros(len(BANDS))
    for b, mask in enumerate(MASKS):
        env = np.abs(np.fft.ifft(np.where(mask, 2.0 * spectrum, 0.0)))
        kurt[b] = (env**4).mean() / (env**2).mean() ** 2
        power = np.abs(np.fft.rfft((env - env.mean()) * HANN)) ** 2
        for j, t in enumerate(TYPES):
            f0 = ORDERS[t] * shaft_hz
            k = int(round(f0 / DF))
            lo, hi = max(1, int((f0 - 40.0) / DF)), int((f0 + 40.0) / DF)
            ring = np.r_[power[lo:k - 2], power[k + 3:hi]]
            levels[b, j] = 10.0 * np.log10(power[k - 1:k + 2].max() / np.median(ring) + 1e-12)
    return levels, kurt


def core_reading(x, shaft_hz):
    """[floor, type] line levels of one window as the core reads them (broad band, two
    harmonics within max(1 bin, 1.5 %)), over the core's floor (row 0) and over the
    local baseline (row 1)."""
    spectrum = np.fft.fft(x - x.mean())
    env = np.abs(np.fft.ifft(np.where(MASKS[0], 2.0 * spectrum, 0.0)))
    power = np.abs(np.fft.rfft((env - env.mean()) * HANN)) ** 2
    k_floor = int(4.0 * ORDERS["IR"] * shaft_hz / DF)
    floor = np.median(power[1:k_floor + 1])
    out = np.zeros((2, len(TYPES)))
    for j, t in enumerate(TYPES):
        peak_sum = local_sum = 0.0
        for h in (1, 2):
            f0 = h * ORDERS[t] * shaft_hz
            tol = max(DF, 0.015 * f0)
            lo, hi = max(1, int((f0 - tol) / DF)), int((f0 + tol) / DF) + 1
            peak = power[lo:hi + 1].max()
            a, b = max(1, int((f0 - 40.0) / DF)), int((f0 + 40.0) / DF) + 1
            peak_sum += peak
            local_sum += peak / np.median(np.r_[power[a:lo], power[hi + 1:b + 1]])
        out[0, j] = 10.0 * np.log10(peak_sum / (2.0 * floor) + 1e-12)
        out[1, j] = 10.0 * np.log10(local_sum / 2.0 + 1e-12)
    return out


def drive_end_records(rows):
    """The 12 kHz drive-end fault records (outer race at 6:00)."""
    for r in rows:
        if r["fault_type"] == "normal" or r["fault_end"] != "DE" or float(r["fs_hz"]) != FS:
            continue
        if r["fault_type"] == "OR" and r["or_position"] != "6:00":
            continue
        yield r


def channel_samples(data, r, channel):
    mat = sio.loadmat(os.path.join(data, r["file"]))
    name = [k for k in mat if k.endswith(f"_{channel}_time")]
    return mat[name[0]].ravel().astype(float) if name else None


def floors(data, rows):
    hits = {}  # (side, floor, type) -> [right, windows]
    bpfi = {}  # label -> local BPFI prominence per window (IR014 and the ball records)
    for r in drive_end_records(rows):
        x = channel_samples(data, r, "DE")
        shaft_hz = float(r["rpm_recorded"] or r["rpm_nominal"]) / 60.0
        side = "test side (0.014)" if r["fault_size_in"] == "0.014" else "training side (0.007 + 0.021)"
        own = TYPES.index(r["fault_type"])
        for s in range(0, len(x) - WINDOW + 1, WINDOW):
            levels = core_reading(x[s:s + WINDOW], shaft_hz)
            if r["cwru_label"].startswith(("IR014", "B")):
                bpfi.setdefault(r["cwru_label"], []).append(levels[1, TYPES.index("IR")])
            for f in (0, 1):
                h = hits.setdefault((side, f, r["fault_type"]), [0, 0])
                h[0] += int(levels[f].argmax() == own)
                h[1] += 1
    print("| side | floor | IR | B | OR | all (window-weighted) |")
    print("|---|---|---:|---:|---:|---:|")
    for side in ("training side (0.007 + 0.021)", "test side (0.014)"):
        for f, name in ((0, "core (median to 4 x BPFI)"), (1, "local (+-40 Hz)")):
            per = [hits[(side, f, t)] for t in ("IR", "B", "OR")]
            total = 100.0 * sum(a for a, _ in per) / sum(n for _, n in per)
            print(f"| {side} | {name} | " + " | ".join(f"{100.0 * a / n:.1f}" for a, n in per)
                  + f" | {total:.2f} |")
    print()
    print("median local BPFI prominence (dB) per record: " + ", ".join(
        f"{label} {np.median(v):.1f}" for label, v in sorted(bpfi.items())))


def main():
    data = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/cwru"
    channel = sys.argv[2] if len(sys.argv) > 2 else "DE"
    rows = list(csv.DictReader(open(os.path.join(data, "MANIFEST.tsv")), delimiter="\t"))
    if channel == "floors":
        floors(data, rows)
        return
    print(f"channel {channel}: share of windows (%) whose strongest line is the record's own; "
          "mean best-band level (dB) of BPFO / BPFI / BSF")
    print("| record | label | windows | broad band | kurtogram band | best band | BPFO | BPFI | BSF |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in drive_end_records(rows):
        x = channel_samples(data, r, channel)
        if x is None:
            continue
        shaft_hz = float(r["rpm_recorded"] or r["rpm_nominal"]) / 60.0
        own = TYPES.index(r["fault_type"])
        levels, kurts = zip(*(line_levels(x[s:s + WINDOW], shaft_hz)
                              for s in range(0, len(x) - WINDOW + 1, WINDOW)))
        levels, kurts = np.array(levels), np.array(kurts)
        pick = kurts.argmax(1)
        broad = levels[:, 0, :].argmax(1) == own
        kurtogram = levels[np.arange(len(levels)), pick, :].argmax(1) == own
        best = levels.max(1)
        share = [100.0 * v.mean() for v in (broad, kurtogram, best.argmax(1) == own)]
        print(f"| {r['cwru_file_no']} | {r['cwru_label']} | {len(levels)} | "
              + " | ".join(f"{v:.0f}" for v in share) + " | "
              + " | ".join(f"{v:.1f}" for v in best.mean(0)) + " |")


main()
