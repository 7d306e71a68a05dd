#!/usr/bin/env bash
# WPI's solver for the dVRK MTM SDP: SCS 1.2.6 (the version their main_mtm.ipynb ran through cvxpy), built from
# its source package in its own environment, build/scs126/venv (its C code predates NumPy 2 and current
# setuptools: NumPy 1.26 and setuptools < 70 there, nothing of it in tendyn's own environment).
# Needs the BLAS/LAPACK development files (Debian: libblas-dev liblapack-dev). Used by
# benchmarks/realdata/_scs126_solve.py (row tendyn_preset_wpi_solver of `make realdata`).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
DEST="${1:-$ROOT/build/scs126}"
PY="${PYTHON:-python3.11}"
if [ -x "$DEST/venv/bin/python" ] && "$DEST/venv/bin/python" -c "import scs; assert scs.__version__ == '1.2.6'" 2>/dev/null; then
    echo "SCS 1.2.6 already in $DEST/venv"; exit 0
fi
rm -rf "$DEST"
mkdir -p "$DEST"
"$PY" -m venv "$DEST/venv"
V="$DEST/venv/bin/python"
"$V" -m pip install --quiet "numpy==1.26.4" "scipy==1.11.4" "setuptools<70" wheel
"$V" -m pip install --quiet --no-build-isolation --no-binary scs --no-cache-dir "scs==1.2.6"
"$V" -c "import scs; print('SCS', scs.__version__, 'in', '$DEST/venv')"
