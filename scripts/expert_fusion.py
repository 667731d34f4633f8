#!/usr/bin/env python3
"""The fusion study of scripts/expert-fusion.sh: every weighting
`alpha·network + gamma·spectral + gamma_k·kinematic` of the DS-STGAT's parts on a grid,
scored on the development protocols and, beside them, on the fault-size test side.

    python3 scripts/expert_fusion.py out/expert-fusion

Development figures (the ones a weighting is chosen by):
  fs-dev      mean clean accuracy over fault-size-dev7 and fault-size-dev21 (4 seeds)
  load/noise  mean of clean, 0 dB and -4 dB accuracy over time-block-dev and
              cross-load-dev0 (4 seeds)
Test figure (never used to choose): fault-size clean accuracy, mean of 3 seeds, and
the windows of each class named, summed over the seeds.
"""
import glob
import json
import os
import re
import sys

import numpy as np

root = sys.argv[1] if len(sys.argv) > 1 else "out/expert-fusion"
DEV_FS = ["fault-size-dev7", "fault-size-dev21"]
DEV_LN = ["time-block-dev", "cross-load-dev0"]


def load(protocol):
    runs = []
    for path in sorted(glob.glob(os.path.join(root, f"{protocol}-*", "experts.json"))):
        if not re.fullmatch(re.escape(protocol) + r"-\d+", os.path.basename(os.path.dirname(path))):
            continue  # `fault-size-*` also matches the dev protocols' runs
        x = json.load(open(path))
        y = np.array(x["label"])
        conds = {}
        for c in x["conditions"]:
            key = "clean" if c["snr_db"] is None else f"{c['snr_db']:g}"
            conds[key] = tuple(np.array(c[k]) for k in ("network", "spectral", "kinematic"))
        runs.append((y, conds, x["classes"], x["weights"]))
    if not runs:
        sys.exit(f"no {protocol}-*/experts.json under {root}: run scripts/expert-fusion.sh")
    return runs


data = {p: load(p) for p in DEV_FS + DEV_LN + ["fault-size"]}
adopted = tuple(data["fault-size"][0][3])


def acc(runs, w, cond="clean"):
    a, g, k = w
    return 100 * np.mean([
        np.mean((a * c[cond][0] + g * c[cond][1] + k * c[cond][2]).argmax(1) == y)
        for y, c, _, _ in runs
    ])


def named(w):
    a, g, k = w
    classes = data["fault-size"][0][2]
    n = np.zeros(len(classes), int)
    for y, c, _, _ in data["fault-size"]:
        p = (a * c["clean"][0] + g * c["clean"][1] + k * c["clean"][2]).argmax(1)
        for i in range(len(classes)):
            n[i] += np.sum((y == i) & (p == i))
    total = [sum(np.sum(y == i) for y, _, _, _ in data["fault-size"]) for i in range(len(classes))]
    return " ".join(f"{cl} {v}/{t}" for cl, v, t in zip(classes, n, total))


def figures(w):
    fs = np.mean([acc(data[p], w) for p in DEV_FS])
    ln = np.mean([acc(data[p], w, c) for p in DEV_LN for c in ("clean", "0", "-4")])
    return fs, ln, acc(data["fault-size"], w)


grid = [(a, g, k) for a in (0.0, 1.0) for g in (0, 1, 2, 4, 8, 16) for k in (0, 1, 2, 4, 8, 16, 32)
        if (a, g, k) != (0.0, 0, 0)]
rows = {w: figures(w) for w in grid}
rows[adopted] = figures(adopted)
fmt = "| {:<22} | {:6.2f} | {:6.2f} | {:6.2f} | {} |"
print(f"runs: {', '.join(f'{p} {len(r)}' for p, r in data.items())}; adopted weights {adopted}")
print("| weighting (network, γ, γ_k) | fs-dev | load/noise | fault-size test | fault-size windows named (3 seeds) |")
print("|---|---:|---:|---:|---|")
for name, w in [("network only", (1, 0, 0)), ("spectral expert only", (0, 1, 0)),
                ("kinematic expert only", (0, 0, 1)), (f"adopted {adopted}", adopted)]:
    print(fmt.format(name, *figures(w), named(w)))
base_ln = rows[adopted][1]
front = sorted((w for w in rows if rows[w][1] >= base_ln - 0.5), key=lambda w: -rows[w][0])[:5]
for w in front:
    print(fmt.format(f"dev front {w}", *rows[w], named(w)))
oracle = max(rows, key=lambda w: rows[w][2])
print(fmt.format(f"test oracle {oracle}", *rows[oracle], named(oracle)))
