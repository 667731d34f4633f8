#!/usr/bin/env bash
# The cage-rate evidence of CWRU's ball records (scripts/ball-cage-evidence.py says
# what and why). Installs numpy and scipy into .venv-probe (gitignored) on first use.
#   bash scripts/ball-cage-evidence.sh [DATA_DIR] [LABEL_PREFIX ...]
set -euo pipefail
cd "$(dirname "$0")/.."
venv=.venv-probe
if ! "$venv/bin/python" -c "import numpy, scipy" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q numpy scipy
fi
data="${1:-../shared/data/cwru}"
shift || true
exec "$venv/bin/python" scripts/ball-cage-evidence.py "$data" "$@"
