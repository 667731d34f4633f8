#!/usr/bin/env python3
"""Choose the physical diagnosis' thresholds and calibrate its confidence on the
development protocol only (`cwru-dev` rows of `pumptwin eval-generalization
--windows-tsv`); no other row is read.

    python3 scripts/diagnosis_thresholds.py WINDOWS.tsv [PROTOCOL]

PROTOCOL: `cwru-dev` (default: the shipped thresholds) or `sim-dev` (the randomized
simulated records of `--sim-records`: the `sim-only` protocol's thresholds).

The thresholds are the defect families': they were chosen before the cage line's rule
(a lineless, impulsive window whose envelope line at FTF reaches CAGE_LINE_DB = 15 dB
and leads every family, and the strongest envelope line above it, by margin_db is a
ball), which borrows margin_db, so the sweep and the calibration
leave that rule out; its claims on the same side are counted after the choice. Rule
(pumptwin_core::diagnosis::Thresholds::DEFAULT says why): over the grid
line_db 8-30 dB x margin_db 1-6 dB x impulsive_sk {0.3 .. 1.5}, keep the settings whose
typed claims are >= 95 % right; among those within 0.5 point of the best mean recall of
the four true types, take the most precise, then the largest kurtosis threshold. Then:
the typed claims' logistic on (lead - margin) with a prior of 5 right and 5 wrong claims
at the margin; and P(normal | called normal) with the true types weighted equally.
"""
import collections
import csv
import math
import sys

FAMILIES = ["outer_race", "inner_race", "ball"]
CAGE_LINE_DB = 15.0  # pumptwin_core::diagnosis::CAGE_LINE_DB


def rows(path, protocol):
    out = []
    for r in csv.DictReader(open(path), delimiter="\t"):
        if r["protocol"] != protocol:
            continue
        levels = [float(r["outer_db"]), float(r["inner_db"]), float(r["ball_db"])]
        out.append((r["truth"], float(r["sk"]), levels, (float(r["cage_db"]), float(r["above_cage_db"]))))
    return out


def decide(sk, lv, cage, line, margin, impulsive, above=0.0):
    order = sorted(range(3), key=lambda i: -lv[i])
    best, lead = lv[order[0]], lv[order[0]] - lv[order[1]]
    if best >= line and lead >= margin:
        return FAMILIES[order[0]], lead - margin
    if best < line and sk < impulsive:
        return "normal", line - best
    if cage is not None and best < line and sk >= impulsive and cage >= CAGE_LINE_DB and cage - max(best, above) >= margin:
        return "ball", cage - max(best, above) - margin
    return "no_clear_signature", 0.0


def sweep(data):
    results = []
    for line in range(8, 31):
        for margin in range(1, 7):
            for impulsive in [0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.5]:
                recall, n = collections.Counter(), collections.Counter()
                claims = wrong = 0
                for truth, sk, lv, _ in data:
                    d, _ = decide(sk, lv, None, line, margin, impulsive)
                    n[truth] += 1
                    recall[truth] += d == truth
                    if d in FAMILIES:
                        claims += 1
                        wrong += d != truth
                mean_recall = sum(recall[t] / n[t] for t in n) / len(n)
                precision = 1 - wrong / max(claims, 1)
                per_type = {t: round(recall[t] / n[t], 3) for t in n}
                results.append((mean_recall, precision, line, margin, impulsive, per_type))
    ok = [r for r in results if r[1] >= 0.95]
    top = max(r[0] for r in ok)
    near = [r for r in ok if r[0] >= top - 0.005]
    near.sort(key=lambda r: (-r[1], -r[4]))
    return near[0]


def logistic(points, ridge=1.0):
    """Newton's method for P(y) = 1 / (1 + exp(-(a x + b))), with a Gaussian prior of
    unit variance on the slope (per dB of lead): without it, claims that are all right
    separate perfectly and the slope runs off to infinity."""
    a = b = 0.0
    for _ in range(100):
        g0, g1 = -ridge * a, 0.0
        h00, h01, h11 = ridge, 0.0, 1e-6
        for x, y in points:
            p = 1 / (1 + math.exp(-(a * x + b)))
            w = p * (1 - p)
            g0 += (y - p) * x
            g1 += y - p
            h00 += w * x * x
            h01 += w * x
            h11 += w
        det = h00 * h11 - h01 * h01
        a += (h11 * g0 - h01 * g1) / det
        b += (-h01 * g0 + h00 * g1) / det
    return a, b


def main():
    data = rows(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else "cwru-dev")
    mean_recall, precision, line, margin, impulsive, per_type = sweep(data)
    print(f"line_db {line}, margin_db {margin}, impulsive_sk {impulsive}: mean recall "
          f"{100 * mean_recall:.1f} %, typed claims {100 * precision:.1f} % right, {per_type}")
    typed, called_normal, n = [], collections.Counter(), collections.Counter()
    cage_claims = collections.Counter()
    for truth, sk, lv, cage in data:
        d, x = decide(sk, lv, None, line, margin, impulsive)
        if decide(sk, lv, cage[0], line, margin, impulsive, cage[1])[0] != d:
            cage_claims[truth] += 1
        n[truth] += 1
        if d in FAMILIES:
            typed.append((x, d == truth))
        elif d == "normal":
            called_normal[truth] += 1
    prior = [(0.0, True)] * 5 + [(0.0, False)] * 5
    a, b = logistic(typed + prior)
    print(f"typed_logistic ({a:.3f}, {b:.3f}) from {len(typed)} claims")
    share = {t: called_normal[t] / n[t] for t in n}
    p = share.get("normal", 0.0) / max(sum(share.values()), 1e-9)
    # Where no faulty window was called normal, p is 1 and its logit infinite: cap it
    # at half a wrong call among the windows called normal.
    p = min(p, 1 - 0.5 / max(sum(called_normal.values()), 1))
    normal_b = math.log(p / (1 - p))
    print(f"P(normal | called normal), types weighted equally: {p:.3f} "
          f"(normal_logistic (0, {normal_b:.2f})); shares called normal {share}")
    print(f"cage-line ball claims at these thresholds, by true type: {dict(cage_claims)}")
    print(f"--sim-thresholds {line},{margin},{impulsive},{a:.3f},{b:.3f},{normal_b:.2f}")


if __name__ == "__main__":
    main()
