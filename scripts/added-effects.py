#!/usr/bin/env python3
"""Effects added to measured CWRU records, for probing `pumptwin twin loop`.

    .venv-probe/bin/python scripts/added-effects.py ../shared/data/cwru OUT_DIR [RECORD ...]

(`bash scripts/linear-probe.sh` makes .venv-probe once.) For each record (default 234
and 118: 12k_DE/<n>.mat) it writes, from the drive-end channel's first 6 s, the record
as it is and with one added effect each, every file a CSV that declares its rate and
speed (`# fs_hz=12000 rpm=…`):

    <n>_base.csv   the record
    <n>_mains.csv  60, 180, 300 Hz at 10, 5, 3 % of the record's RMS
    <n>_vane.csv   7x and 14x the shaft rate at 15 and 6 % (a seven-vane impeller)
    <n>_tone.csv   437.3 Hz at 10 %
    <n>_loose.csv  1.5x, 2.5x, 3.5x at 10, 8, 6 % (looseness)

and prints each added line's prominence over the median of the Welch PSD (4096-point
Hann) within +-40 Hz, with and without the effect. Then run

    pumptwin twin loop --input OUT_DIR/<n>_<effect>.csv --out OUT_DIR/<n>_<effect>
"""
import sys
from pathlib import Path

import numpy as np
import scipy.io as sio
from scipy.signal import welch

FS = 12000


def main():
    data, out = Path(sys.argv[1]), Path(sys.argv[2])
    records = sys.argv[3:] or ["234", "118"]
    out.mkdir(parents=True, exist_ok=True)
    for n in records:
        m = sio.loadmat(data / "12k_DE" / f"{n}.mat")
        de = [k for k in m if k.endswith("DE_time")][0]
        x = m[de].ravel()[: 6 * FS].astype(float)
        rpm_keys = [k for k in m if k.endswith("RPM")]
        rpm = float(m[rpm_keys[0]].ravel()[0]) if rpm_keys else 1797.0
        t = np.arange(len(x)) / FS
        fr = rpm / 60
        rms = x.std()
        effects = {
            "base": [],
            "mains": [(60, 0.1, 0), (180, 0.05, 1), (300, 0.03, 2)],
            "vane": [(7 * fr, 0.15, 0), (14 * fr, 0.06, 1)],
            "tone": [(437.3, 0.1, 0)],
            "loose": [(1.5 * fr, 0.1, 0), (2.5 * fr, 0.08, 1), (3.5 * fr, 0.06, 2)],
        }
        _, p_base = welch(x, FS, nperseg=4096, window="hann")
        for name, tones in effects.items():
            y = x + sum(a * rms * np.sin(2 * np.pi * f * t + ph) for f, a, ph in tones)
            path = out / f"{n}_{name}.csv"
            with open(path, "w") as fh:
                fh.write(f"# fs_hz={FS} rpm={rpm}\nDE\n")
                fh.write("\n".join(f"{v:.6f}" for v in y) + "\n")
            if not tones:
                continue
            _, p = welch(y, FS, nperseg=4096, window="hann")
            rows = []
            for f, _, _ in tones:
                k = int(round(f / (FS / 4096)))
                lo, hi = max(1, k - 14), k + 14
                prom = lambda q: 10 * np.log10(q[k - 1 : k + 2].max()) - np.median(10 * np.log10(q[lo : hi + 1]))
                rows.append(f"{f:.1f} Hz {prom(p):+.1f} dB (record alone {prom(p_base):+.1f})")
            print(f"{n} {name} (RMS {rms:.3f} g): " + "; ".join(rows))


if __name__ == "__main__":
    main()
