#!/usr/bin/env bash
# Install everything, then run the main job: the hardware-free assembly demo.
# First the ROS 2 cell: mock arm and sensor, dynamic compensation, kinematics and the FBCC
# controller as nodes over DDS perform one assembly (fbcc_bringup; exit status 1 if it fails),
# recorded into a bag, which is then reported (fbcc-report) and replayed offline (fbcc_replay).
# Then the paper's Fig. 9 comparison, FBCC against admittance, simulated for both fits; the
# iiwa's TCP solution following the FBCC run; and the state maps of Fig. 5 and 6.
# Everything is written to out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
out="${1:-out/demo}"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
.venv/bin/python -m fbcc_ros.nodes.bringup config/scenarios/bringup_interference.yaml \
    --out "$out/bringup"
# the session it recorded: its report, and the offline replay of its commands
bag="$(.venv/bin/python -c 'import json, sys; print(json.load(open(sys.argv[1]))["bag"]["path"])' \
    "$out/bringup/summary.json")"
.venv/bin/python -m fbcc_ros.cli.report "$bag" --out "$out/bringup/report"
.venv/bin/python -m fbcc_ros.nodes.fbcc_replay "$bag" --offline --out "$out/bringup/offline"
for fit in clearance interference; do
    .venv/bin/python -m fbcc_ros.cli.sim "config/scenarios/fig9_${fit}.yaml" --out "$out/fig9_${fit}"
done
.venv/bin/python -m fbcc_ros.cli.kinematics config/scenarios/fig9_interference.yaml \
    --robot iiwa14 --out "$out/kinematics_iiwa14"
.venv/bin/python -m fbcc_ros.cli.maps --out "$out/maps"
