#!/usr/bin/env bash
# Install everything, then run the main job: the hardware-free demo.
# For now (issue 2): contact responses of the paper's peg-hole pairs and the state maps of
# Fig. 5 and 6, written to out/demo/. Later issues turn this into the full assembly.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
.venv/bin/python -m fbcc_ros.cli.maps --out "${1:-out/demo}"
