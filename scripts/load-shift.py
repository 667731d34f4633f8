#!/usr/bin/env python3
"""Which node features of a class move at 3 HP, and toward which other class.

    python3 scripts/load-shift.py CLASS OTHER [DATA_DIR]
    e.g. python3 scripts/load-shift.py B014 IR021

For every node and feature: z = (mean over the 3 HP record's windows − mean over the
0-2 HP windows of CLASS) / std of those 0-2 HP windows, and the same z of OTHER's 0-2 HP
mean ("z other"); "toward" says whether the 3 HP shift points toward OTHER. A feature
row is the mean over a window's segments. Prints the 20 largest |z|; features with no
spread at 0-2 HP (a band share at its floor) are left out. Runs `pumptwin features` per
record (release build). Measured 2026-11-24 (docs/evaluation-cwru.md, seventh round):
B014's fan-end RMS +7.2, bandwidth -5.8, both toward IR021; no DE feature beyond 2.6.
"""
import statistics as st
import sys
import tempfile

from cwru_features import manifest, record_features

cls, other = sys.argv[1], sys.argv[2]
data = sys.argv[3] if len(sys.argv) > 3 else "../shared/data/cwru"
rows = {r["cwru_label"]: r for r in manifest(data)}


def label(c, hp):
    for k in (f"{c}_{hp}", f"{c}@6_{hp}"):  # outer-race labels carry the position
        if k in rows:
            return k
    sys.exit(f"no record {c}_{hp} in MANIFEST.tsv")


def windows(c, hp, tmp):
    d = record_features(data, rows[label(c, hp)], tmp)
    nodes, names = len(d["windows"][0]["features_raw"][0]), d["feature_names"]
    # [window][node][feature], averaged over segments
    return names, nodes, [[[st.fmean(seg[i][f] for seg in w["features_raw"]) for f in range(len(names))]
                           for i in range(nodes)] for w in d["windows"]]


with tempfile.TemporaryDirectory() as tmp:
    names, nodes, _ = windows(cls, 0, tmp)
    train = [w for hp in (0, 1, 2) for w in windows(cls, hp, tmp)[2]]
    test = windows(cls, 3, tmp)[2]
    oth = [w for hp in (0, 1, 2) for w in windows(other, hp, tmp)[2]]
node_names = ["DE", "FE", "BA"] + [f"node{i}" for i in range(3, nodes)]
res = []
for i in range(nodes):
    for f, name in enumerate(names):
        tr = [w[i][f] for w in train]
        mu, sd = st.fmean(tr), st.pstdev(tr)
        if sd < 1e-6 * max(1.0, abs(mu)):
            continue
        z = (st.fmean(w[i][f] for w in test) - mu) / sd
        zo = (st.fmean(w[i][f] for w in oth) - mu) / sd
        res.append((abs(z), node_names[i], name, z, zo, (z > 0) == (zo > 0)))
res.sort(reverse=True)
print(f"{cls} at 3 HP against {cls} at 0-2 HP (z), and {other} at 0-2 HP (z other)")
for _, node, name, z, zo, toward in res[:20]:
    print(f"{node:4s} {name:14s} z {z:+7.2f}  z other {zo:+7.2f}  {'toward' if toward else 'away'}")
