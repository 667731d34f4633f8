#!/usr/bin/env python3
"""The fusion study of scripts/expert-fusion.sh: how the DS-STGAT's parts are weighed,
`alpha·network + gamma·spectral + gamma_k·kinematic + vote(tau, beta)`, scored on the
development protocols and, beside them, on the fault-size test side.

    python3 scripts/expert_fusion.py out/expert-fusion

The vote is the core's defect-line vote (core/src/dsstgat.rs, LineVote), recomputed
here from node 0's envelope lines that `eval --experts` writes, so that its threshold
tau and weight beta can be studied on the same runs:
    vote_c = beta · max(0, L_line(c) − tau),  L in dB over the envelope median,
    line(c): OR → BPFO, IR → BPFI, B → BSF, none for `normal`.

Development figures (the ones a setting is chosen by):
  fs-dev      mean clean accuracy over fault-size-dev7 and fault-size-dev21 (4 seeds)
  load/noise  mean of clean, 0 dB and −4 dB accuracy over time-block-dev and
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
CHOSEN = (7.0, 2.0)  # LINE_VOTE_THRESHOLD_DB, LINE_VOTE_WEIGHT in core/src/dsstgat.rs


def defect_line(name):
    if name.startswith("OR"):
        return 0
    if name.startswith("IR"):
        return 1
    if name == "B" or (name.startswith("B") and name[1:2].isdigit()):
        return 2
    return None


def load(protocol):
    runs = []
    for path in sorted(glob.glob(os.path.join(root, f"{protocol}-*", "experts.json"))):
        if not re.fullmatch(re.escape(protocol) + r"-\d+", os.path.basename(os.path.dirname(path))):
            continue  # `fault-size-*` also matches the dev protocols' runs
        x = json.load(open(path))
        lines = [defect_line(c) for c in x["classes"]]
        onehot = np.zeros((3, len(lines)))
        for c, l in enumerate(lines):
            if l is not None:
                onehot[l, c] = 1.0
        conds = {}
        for c in x["conditions"]:
            key = "clean" if c["snr_db"] is None else f"{c['snr_db']:g}"
            db = np.array([[np.nan] * 3 if v is None else v for v in c["node0_lines_db"]])
            conds[key] = [np.array(c[k]) for k in ("network", "spectral", "kinematic")] + [db]
        runs.append((np.array(x["label"]), conds, x["classes"], onehot))
    if not runs:
        sys.exit(f"no {protocol}-*/experts.json under {root}: run scripts/expert-fusion.sh")
    return runs


data = {p: load(p) for p in DEV_FS + DEV_LN + ["fault-size"]}


def logits(parts, onehot, w, vote):
    a, g, k = w
    net, spec, kin, db = parts
    out = a * net + g * spec + k * kin
    if vote is not None:
        tau, beta = vote
        strength = np.nan_to_num(np.maximum(beta * (db - tau), 0.0))
        out = out + strength @ onehot
    return out


def acc(runs, w, vote, cond="clean"):
    return 100 * np.mean([
        np.mean(logits(c[cond], oh, w, vote).argmax(1) == y) for y, c, _, oh in runs
    ])


def named(w, vote):
    classes = data["fault-size"][0][2]
    n = np.zeros(len(classes), int)
    total = np.zeros(len(classes), int)
    for y, c, _, oh in data["fault-size"]:
        p = logits(c["clean"], oh, w, vote).argmax(1)
        for i in range(len(classes)):
            n[i] += np.sum((y == i) & (p == i))
            total[i] += np.sum(y == i)
    return ", ".join(f"{cl} {v}/{t}" for cl, v, t in zip(classes, n, total))


def figures(w, vote):
    fs = np.mean([acc(data[p], w, vote) for p in DEV_FS])
    ln = np.mean([acc(data[p], w, vote, c) for p in DEV_LN for c in ("clean", "0", "-4")])
    return fs, ln, acc(data["fault-size"], w, vote)


ADOPTED = (1.0, 4.0, 4.0)  # SENSOR_HEAD_WEIGHT, KINEMATIC_HEAD_WEIGHT in trainer/src/model.rs
HEAD = ("| {} | fs-dev | load/noise | fault-size test | fault-size windows named (3 seeds) |\n"
        "|---|---:|---:|---:|---|")
row = "| {:<34} | {:6.2f} | {:6.2f} | {:6.2f} | {} |"
print(f"runs: {', '.join(f'{p} {len(r)}' for p, r in data.items())}\n")

print("1. The parts alone and together")
print(HEAD.format("part or weighting (network, γ, γ_k) + vote"))
for name, w, v in [("network only", (1, 0, 0), None), ("spectral expert only", (0, 1, 0), None),
                   ("kinematic expert only", (0, 0, 1), None),
                   (f"vote only (τ, β) = {CHOSEN}", (0, 0, 0), CHOSEN),
                   (f"{ADOPTED}, no vote", ADOPTED, None),
                   (f"{ADOPTED} + vote {CHOSEN}", ADOPTED, CHOSEN)]:
    print(row.format(name, *figures(w, v), named(w, v)))

base_ln = figures(ADOPTED, None)[1]
print(f"\n2. The vote's threshold τ (dB) and weight β on the adopted weighting: the best "
      f"fs-dev with load/noise ≥ {base_ln:.2f} − 0.1 (the weighting without the vote)")
print(HEAD.format("(τ, β)"))
grid = {(t, b): figures(ADOPTED, (t, b)) for t in (6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0)
        for b in (1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0)}
kept = sorted((v for v in grid if grid[v][1] >= base_ln - 0.1), key=lambda v: -grid[v][0])
for v in kept[:6]:
    print(row.format(f"{v}{' (chosen)' if v == kept[0] else ''}", *grid[v], named(ADOPTED, v)))
for v in sorted(grid, key=lambda v: -grid[v][0])[:3]:
    print(row.format(f"{v} (best fs-dev, load/noise not kept)", *grid[v], named(ADOPTED, v)))

print(f"\n3. Weightings of the parts with the vote {CHOSEN}: the development front (best "
      "fs-dev among those that keep load/noise within 0.5 of the adopted one) and the best "
      "on the test side itself (an oracle, not a result)")
print(HEAD.format("weighting (network, γ, γ_k) + vote"))
weights = [(a, g, k) for a in (0.0, 1.0) for g in (0, 1, 2, 4, 8, 16)
           for k in (0, 1, 2, 4, 8, 16, 32)]
rows = {w: figures(w, CHOSEN) for w in weights}
adopted_ln = figures(ADOPTED, CHOSEN)[1]
for w in sorted((w for w in rows if rows[w][1] >= adopted_ln - 0.5), key=lambda w: -rows[w][0])[:5]:
    print(row.format(f"dev front {w}", *rows[w], named(w, CHOSEN)))
oracle = max(rows, key=lambda w: rows[w][2])
print(row.format(f"test oracle {oracle}", *rows[oracle], named(oracle, CHOSEN)))
no_vote = {w: figures(w, None) for w in weights}
oracle = max(no_vote, key=lambda w: no_vote[w][2])
print(row.format(f"test oracle {oracle}, no vote", *no_vote[oracle], named(oracle, None)))
