#!/usr/bin/env bash
# A linear read of the node features, per sensor and shared by the sensors, on the
# load-shift protocols: the evidence behind the DS-STGAT's sensor head
# (trainer/src/model.rs, SENSOR_HEAD_WEIGHT; docs/evaluation-cwru.md).
#
#   bash scripts/linear-probe.sh [DATA_DIR]
#
# Installs numpy and scikit-learn into .venv-probe (gitignored) on first use, runs
# `pumptwin features` per record (release build) and prints, per protocol, the
# accuracy of a logistic regression (scikit-learn, C = 1, standardized inputs) on the
# window-mean features: one weight row per sensor (DE, DE+FE, all three), one row
# shared by the sensors, and per sensor on the sixteen log band shares alone; then the
# same probe on `fault-size` (fault type from the 0.007" and 0.021" records, tested on
# 0.014") with all features, the envelope features, or the band shares; last, the
# fault-size development splits (one end size to the other), where the sensor head's
# kinematic expert was chosen.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=.venv-probe
if ! "$venv/bin/python" -c "import numpy, sklearn" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q numpy scikit-learn
fi
exec "$venv/bin/python" scripts/linear_probe.py "${1:-../shared/data/cwru}"
