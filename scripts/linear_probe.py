"""See scripts/linear-probe.sh."""
import sys
import tempfile
import warnings

import numpy as np
from sklearn.linear_model import LogisticRegression
from sklearn.preprocessing import StandardScaler

from cwru_features import manifest, record_features

warnings.filterwarnings("ignore")
data = sys.argv[1]
rows = [r for r in manifest(data) if r["fault_type"] != "normal"]
names = None
feats = {}  # label -> [windows, nodes, features]: the mean over a window's segments
with tempfile.TemporaryDirectory() as tmp:
    for r in rows:
        f = record_features(data, r, tmp)
        names = f["feature_names"]
        x = np.array([w["features_raw"] for w in f["windows"]], dtype=float)
        feats[r["cwru_label"]] = (np.nan_to_num(x).mean(1), r)
bands = [i for i, n in enumerate(names) if n.startswith("band_db_")]


def cls(r):
    return r["fault_type"] + r["fault_size_in"][2:]


def split(train_loads, test_load):
    tr = [(x, cls(r)) for x, r in feats.values() if r["load_hp"] in train_loads]
    te = [(x, cls(r)) for x, r in feats.values() if r["load_hp"] == test_load]
    return tr, te


def fit(tr, view):
    """The probe on the (window means, class) pairs `tr` read through `view`: the
    sorted classes, the standardizer and the logistic regression (C = 1)."""
    classes = sorted({c for _, c in tr})
    xtr = np.concatenate([view(x) for x, _ in tr])
    ytr = np.concatenate([[classes.index(c)] * len(x) for x, c in tr])
    s = StandardScaler().fit(xtr)
    return classes, s, LogisticRegression(C=1.0, max_iter=5000).fit(s.transform(xtr), ytr)


def accuracy(tr, te, view):
    classes, s, m = fit(tr, view)
    ok = n = 0
    for x, c in te:
        ok += int((m.predict(s.transform(view(x))) == classes.index(c)).sum())
        n += len(x)
    return 100.0 * ok / n


def per_sensor(nodes, fi=None):
    return lambda x: (x[:, nodes] if fi is None else x[:, nodes][:, :, fi]).reshape(len(x), -1)


def shared(x):  # one row for every sensor: the sum of the sensors' features (linear)
    return x.sum(1)


print("protocol         | per sensor: DE | DE+FE  | DE+FE+BA | shared by the sensors | per sensor, band shares")
for name, train, test in [("cross-load", "012", "3"), ("cross-load-dev0", "12", "0"),
                          ("cross-load-dev", "01", "2")]:
    tr, te = split(set(train), test)
    a = [accuracy(tr, te, v) for v in (per_sensor([0]), per_sensor([0, 1]), per_sensor([0, 1, 2]),
                                         shared, per_sensor([0, 1, 2], bands))]
    print(f"{name:<16} | {a[0]:6.2f}         | {a[1]:6.2f} | {a[2]:6.2f}   | {a[3]:6.2f}                | {a[4]:6.2f}")

# fault-size: fault type (IR, B, OR) from the 0.007" and 0.021" records, tested on 0.014"
envelope = [i for i, n in enumerate(names) if n.startswith("env_") and n != "env_kurtosis"]
envelope.append(names.index("env_kurtosis"))
fs_tr = [(x, r["fault_type"]) for x, r in feats.values() if r["fault_size_in"] in ("0.007", "0.021")]
fs_te = [(x, r["fault_type"], r) for x, r in feats.values() if r["fault_size_in"] == "0.014"]


def fs_accuracy(view):
    classes, s, m = fit(fs_tr, view)
    by = {}
    for x, c, r in fs_te:
        ok = int((m.predict(s.transform(view(x))) == classes.index(c)).sum())
        k = r["fault_type"] + r["fault_size_in"][2:]
        a, n = by.get(k, (0, 0))
        by[k] = (a + ok, n + len(x))
    total = 100.0 * sum(a for a, _ in by.values()) / sum(n for _, n in by.values())
    return total, {k: f"{100.0 * a / n:.0f}" for k, (a, n) in sorted(by.items())}


print()
print("fault-size (0.007 + 0.021 -> 0.014), per sensor | accuracy % | per class % named")
for label, nodes, fi in [("all features, DE", [0], None), ("all features, DE+FE+BA", [0, 1, 2], None),
                         ("envelope features, DE", [0], envelope),
                         ("envelope features, DE+FE+BA", [0, 1, 2], envelope),
                         ("band shares, DE", [0], bands), ("band shares, DE+FE+BA", [0, 1, 2], bands),
                         ("envelope + band shares, DE", [0], envelope + bands)]:
    acc, by = fs_accuracy(per_sensor(nodes, fi))
    print(f"{label:<30} | {acc:6.2f} | {by}")

# The development splits inside fault-size's training side (fault-size-dev7 and
# fault-size-dev21: fault type from one end size, named on the other; 0.014" unused):
# one regression per feature set, and two regressions (band shares, envelope) whose
# decision values add — the sensor head's two experts (trainer/src/model.rs,
# KINEMATIC_HEAD_WEIGHT).


def size_accuracy(train_size, test_size, experts):
    tr = [(x, r["fault_type"]) for x, r in feats.values() if r["fault_size_in"] == train_size]
    models = [(view, *fit(tr, view)) for view in experts]
    classes = models[0][1]  # every expert sees the same pairs: the same sorted classes
    ok = n = 0
    for x, r in feats.values():
        if r["fault_size_in"] != test_size:
            continue
        z = sum(m.decision_function(s.transform(view(x))) for view, _, s, m in models)
        ok += int((z.argmax(1) == classes.index(r["fault_type"])).sum())
        n += len(x)
    return 100.0 * ok / n


print()
print("fault-size development splits, per sensor | -dev7 (0.021 -> 0.007) | -dev21 (0.007 -> 0.021) | mean")
all3 = [0, 1, 2]
for label, experts in [("envelope features, DE", [per_sensor([0], envelope)]),
                       ("envelope features, DE+FE+BA", [per_sensor(all3, envelope)]),
                       ("band shares, DE", [per_sensor([0], bands)]),
                       ("band shares, DE+FE+BA", [per_sensor(all3, bands)]),
                       ("envelope + band shares, DE+FE+BA", [per_sensor(all3, envelope + bands)]),
                       ("two experts: bands | envelope, DE+FE+BA",
                        [per_sensor(all3, bands), per_sensor(all3, envelope)])]:
    a = size_accuracy("0.021", "0.007", experts)
    b = size_accuracy("0.007", "0.021", experts)
    print(f"{label:<42} | {a:6.2f} | {b:6.2f} | {(a + b) / 2:6.2f}")
