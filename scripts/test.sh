#!/usr/bin/env bash
# Install everything, then run the checks CI runs: lint, types, the test suite, the benchmark
# in its short mode, and the colcon build of the package.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
echo "== ruff"; .venv/bin/ruff check fbcc_ros test
echo "== mypy (the whole package)"; .venv/bin/mypy
echo "== benchmark (short mode: proves it runs; figures are only meaningful in full mode)"
.venv/bin/python -m fbcc_ros.cli.bench --short
echo "== pytest"; .venv/bin/python -m pytest "$@"
