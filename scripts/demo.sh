#!/usr/bin/env bash
# Install everything, then run the main job: the hardware-free assembly demo.
# For now (issues 3-4): the paper's Fig. 9 comparison, FBCC against admittance, simulated in
# closed loop for both fits; the iiwa's TCP solution following the FBCC run; and the state maps of
# Fig. 5 and 6. Everything is written to out/demo/.
# The ROS 2 bringup replaces the simulator here with the nodes issue.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/bootstrap.sh
out="${1:-out/demo}"
for fit in clearance interference; do
    .venv/bin/python -m fbcc_ros.cli.sim "config/scenarios/fig9_${fit}.yaml" --out "$out/fig9_${fit}"
done
.venv/bin/python -m fbcc_ros.cli.kinematics config/scenarios/fig9_interference.yaml \
    --robot iiwa14 --out "$out/kinematics_iiwa14"
.venv/bin/python -m fbcc_ros.cli.maps --out "$out/maps"
