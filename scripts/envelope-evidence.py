#!/usr/bin/env python3
"""Kinematic evidence per CWRU record: the mean over a record's windows of the core's
envelope features (dB over the envelope spectrum's median at shaft rate, BPFO, BPFI,
BSF) on the DE and FE nodes, with DE RMS and kurtosis. It shows which 0.014" records
carry their defect's signature (the fault-size protocol's test side).

    python3 scripts/envelope-evidence.py [DATA_DIR] [HP]

Runs `pumptwin features` (release build) per record.

What it shows (measured 2026-11-24 with the 28 features, every load 0-3 HP): OR014 (records 197-200) has no
outer-race signature in any channel at any load -- no envelope line above 7.8 dB at DE
(OR007/OR021: 17-25 dB), FE BPFO at most 11.5 dB (as the ball records), DE kurtosis
2.9-3.3 (Gaussian; the core's noise-compensated kurtosis, `kurtosis_nc`, turned back
into a kurtosis) and the lowest RMS of all fault records (0.087-0.099 g, amplitude
that says "ball"). It looks like a healthy bearing. On the fault-size protocol's test
side (IR014 468, B014 471, OR014 470 windows) a classifier that cannot name OR014 is
capped at (468 + 471) / 1409 = 66.6 %, below the 67 % target.
"""
import math
import statistics as st
import sys
import tempfile

from cwru_features import manifest, record_features

data = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/cwru"
hp = sys.argv[2] if len(sys.argv) > 2 else "0"
rows = manifest(data)
print("| record | label | DE shaft | DE BPFO | DE BPFI | DE BSF | FE BPFO | FE BPFI | FE BSF | DE rms g | DE kurtosis |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
with tempfile.TemporaryDirectory() as tmp:
    for r in rows:
        if r["fault_type"] == "normal" or not r["cwru_label"].endswith("_" + hp):
            continue
        d = record_features(data, r, tmp)
        names = d["feature_names"]
        w = [x["features_raw"][0] for x in d["windows"]]  # first step: envelope rows are per window

        def excess(v):  # kurtosis_nc = sign(k) ln(1 + |k|), k the excess kurtosis
            return math.copysign(math.expm1(abs(v)), v)

        def m(node, name):
            return st.mean(f[node][names.index(name)] for f in w)

        de = [m(0, n) for n in ("env_shaft_db", "env_bpfo_db", "env_bpfi_db", "env_bsf_db")]
        fe = [m(1, n) for n in ("env_bpfo_db", "env_bpfi_db", "env_bsf_db")]
        print(f"| {r['cwru_file_no']} | {r['cwru_label']} | " + " | ".join(f"{v:.1f}" for v in de + fe)
              + f" | {m(0, 'rms'):.3f} | {3 + excess(m(0, 'kurtosis_nc')):.1f} |")
