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
if [ $# -gt 0 ]; then
  echo "== pytest"; .venv/bin/python -m pytest "$@"
else
  # the tests off the wall clock on every core, then the real-time ones (live cells over DDS,
  # marked in test/conftest.py) alone, one at a time: both run, and both must pass
  status=0
  echo "== pytest: the tests off the wall clock, on every core"
  .venv/bin/python -m pytest -m "not realtime" -n auto --durations=15 || status=$?
  echo "== pytest: the real-time tests, one at a time"
  .venv/bin/python -m pytest -m realtime --durations=15 --rerun-show-tracebacks || status=$?
  [ "$status" -eq 0 ] || exit "$status"
fi
# the launch file with the real Jazzy `ros2 launch`, built from the sources ../shared carries
# (not a dependency of the package: skipped where they are not)
if [ -f ../shared/ros2cli.sh ] && [ $# -eq 0 ]; then
  echo "== ros2 launch (the real Jazzy CLI, ../shared/ros2cli.sh)"
  ( set +eu; . ../shared/ros2cli.sh && .venv/bin/python -m pytest test/test_launch_file.py )
fi
