#!/usr/bin/env bash
# Create .venv in the checkout and install everything fbcc_ros needs from PyPI (PLATFORM.md).
# Idempotent: a second run only checks that the pinned requirements are satisfied.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "[bootstrap] creating .venv with $($PY --version)"
  "$PY" -m venv .venv
  # colcon crawls the tree it builds; keep it out of the venv (PLATFORM.md pitfall)
  touch .venv/COLCON_IGNORE
fi
stamp=.venv/.requirements.sha
want=$(sha256sum requirements.txt setup.py | sha256sum | cut -c1-16)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  echo "[bootstrap] installing requirements into .venv (about a minute on a fresh machine)"
  .venv/bin/python -m pip install --quiet --disable-pip-version-check -r requirements.txt
  .venv/bin/python -m pip install --quiet --disable-pip-version-check --no-deps -e .
  echo "$want" > "$stamp"
fi
.venv/bin/python -c "import rclpy, numpy, pinocchio, mcap, fbcc_ros" \
  || { echo "[bootstrap] the environment is broken: delete .venv and run again" >&2; exit 1; }
echo "[bootstrap] .venv ready"
