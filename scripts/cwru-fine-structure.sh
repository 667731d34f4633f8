#!/usr/bin/env bash
# How close a smooth structure can come to a CWRU record's spectrum (scripts/cwru-fine-structure.py says
# what and why). Installs numpy and scipy into .venv-probe (gitignored) on first use.
#   bash scripts/cwru-fine-structure.sh [DATA_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
venv=.venv-probe
if ! "$venv/bin/python" -c "import numpy, scipy" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q numpy scipy
fi
data="${1:-../shared/data/cwru}"
shift || true
exec "$venv/bin/python" scripts/cwru-fine-structure.py "$data" "$@"
