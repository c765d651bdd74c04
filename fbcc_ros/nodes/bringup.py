"""fbcc_bringup: the whole hardware-free cell, one assembly, a summary, an exit status.

    fbcc_bringup [SCENARIO.yaml] [--law fbcc|admittance|none] [--out DIR] [--draw-geometry]

Starts the four nodes (mock_cell, dynamic_compensation, kinematics, fbcc_controller) in one
process on rclpy's EventsExecutor, over real DDS. The compensation tares the sensor (no contact
yet), then the controller starts the insertion, and the cell runs for the scenario's duration.
The true features and responses the mock recorded are scored exactly as ``fbcc-sim`` scores a
simulation; the summary is printed and written to DIR/summary.json. Exit status 0 when the
assembly succeeded, 1 when it did not (or the controller faulted), 2 on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.core import scenario as scenario_io
from fbcc_ros.core.compensation import acting_point_of
from fbcc_ros.core.errors import FbccError
from fbcc_ros.core.simulation import score

DEFAULT_SCENARIO = "config/scenarios/bringup_interference.yaml"
#: Readings averaged into the sensor's bias before the insertion starts.
TARE_SAMPLES = 200


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fbcc_bringup", description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default=DEFAULT_SCENARIO)
    parser.add_argument("--law", choices=("fbcc", "admittance", "none"), default=None)
    parser.add_argument("--out", type=Path, default=None, help="folder for summary.json")
    parser.add_argument("--draw-geometry", action="store_true",
                        help="true radii drawn from Table II's tolerances")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0)
    return parser


def run_cell(
    scenario_path: str, law: str, draw_geometry: bool = False, seed: int = 0
) -> dict[str, Any]:
    """One assembly through the ROS graph, in this process; returns the summary."""
    import rclpy
    from rclpy.experimental import EventsExecutor
    from rclpy.parameter import Parameter

    from fbcc_ros.nodes.dynamic_compensation import DynamicCompensationNode
    from fbcc_ros.nodes.fbcc_controller import FbccControllerNode
    from fbcc_ros.nodes.kinematics import KinematicsNode
    from fbcc_ros.nodes.mock_cell import MockCellNode
    from fbcc_ros.nodes.params import find_scenario

    path = str(find_scenario(scenario_path))
    sc = scenario_io.load(path)
    acting = acting_point_of(sc.geometry).tolist()
    context = rclpy.Context()
    rclpy.init(context=context)
    nodes: list[Any] = []
    try:
        p = Parameter
        mock = MockCellNode(
            record=True,
            context=context,
            parameter_overrides=[
                p("scenario", value=path),
                p("draw_geometry", value=draw_geometry),
                p("seed", value=seed),
            ],
        )
        comp = DynamicCompensationNode(
            context=context,
            parameter_overrides=[
                p("sensor_xyz", value=acting),
                p("acting_point", value=acting),
                p("tare_samples", value=TARE_SAMPLES),
            ],
        )
        kin = KinematicsNode(
            context=context, parameter_overrides=[p("peg_radius", value=sc.geometry.peg_radius)]
        )
        ctrl = FbccControllerNode(
            context=context,
            parameter_overrides=[
                p("scenario", value=path),
                p("law", value=law),
                p("rate_hz", value=sc.rate_hz),
            ],
        )
        nodes = [mock, comp, kin, ctrl]  # fmt: skip
        executor = EventsExecutor(context=context)
        for node in nodes:
            executor.add_node(node)
        # tare, then start; give up if the graph does not come up
        deadline = time.monotonic() + 10.0
        while comp.comp.counts["accepted"] == 0 or ctrl.sup.features is None:
            executor.spin_once(timeout_sec=0.01)
            if time.monotonic() > deadline:
                raise FbccError("the cell did not come up within 10 s (no compensated wrench)")
        ok, message = ctrl.start_insertion(ctrl.now())
        if not ok:
            raise FbccError(f"could not start: {message}")
        start_index = len(mock.truth)
        t_end = time.monotonic() + sc.duration
        last_report = 0.0
        while time.monotonic() < t_end:
            executor.spin_once(timeout_sec=0.01)
            elapsed = sc.duration - (t_end - time.monotonic())
            if elapsed - last_report >= 1.0:
                last_report = elapsed
                depth = mock.truth[-1][1][2] * 1e3 if mock.truth else 0.0
                print(f"  t = {elapsed:4.1f} s  phase {ctrl.sup.phase:10s} depth {depth:.3f} mm",
                      flush=True)  # fmt: skip
        truth = mock.truth[start_index:]
        t = np.array([x[0] for x in truth])
        outcome = score(
            sc, t - t[0], np.array([x[1] for x in truth]), np.array([x[2] for x in truth]),
            ctrl.sup.phase == "force_limit",
        )  # fmt: skip
        summary = outcome.summary(0)
        summary.update(
            scenario=sc.name,
            law=law,
            phase=ctrl.sup.phase,
            reason=ctrl.sup.reason,
            cycles={"mock_ticks": len(truth), "expected": round(sc.duration * sc.rate_hz),
                    "compensated": comp.comp.counts["accepted"],
                    "commands_refused": mock.rejected, "ik_failures": kin.failures},
        )  # fmt: skip
        summary["success"] = bool(summary["success"]) and ctrl.sup.phase != "fault"
        return summary
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown(context=context)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        from fbcc_ros.nodes.params import find_scenario

        sc = scenario_io.load(find_scenario(args.scenario))
        law = args.law or sc.laws[0]
        print(
            f"fbcc_bringup: {sc.name}, law {law}, {sc.duration:.1f} s at {sc.rate_hz:.0f} Hz "
            "(mock cell, compensation, kinematics, controller over DDS)",
            flush=True,
        )
        summary = run_cell(args.scenario, law, args.draw_geometry, args.seed)
    except FbccError as exc:
        print(f"fbcc_bringup: {exc}", file=sys.stderr)
        return 2
    final = summary["final_features"]
    print(
        f"{'assembled' if summary['success'] else 'NOT assembled'}: phase {summary['phase']}"
        f"{' (' + summary['reason'] + ')' if summary['reason'] else ''}; final depth "
        f"{final['l'] * 1e3:.3f} mm, dx {final['dx'] * 1e6:.1f} µm, theta_y "
        f"{np.degrees(final['theta_y']):.3f}°; peak Fz {summary['peak_fz']:.1f} N; "
        f"{summary['cycles']['mock_ticks']}/{summary['cycles']['expected']} cycles"
    )
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        print(f"wrote {args.out / 'summary.json'}")
    return 0 if summary["success"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
