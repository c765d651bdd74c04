"""fbcc-report: what happened in a recorded session, read from its bag.

    fbcc-report BAG [--out DIR] [--scenario FILE]

BAG is a bag folder or ``.mcap`` of the cell (``fbcc_bringup`` records one per session;
``fbcc_record`` on a real cell). It needs the measured features (``fbcc/features``) and the
compensated wrench (``ft_sensor/compensated``); it uses the commands, the phase and the mock's
truth when they are there. The nominal geometry (for the features and the segmentation) is the
controller's scenario, from the bag's ``fbcc_params.yaml`` or ``--scenario``.

Writes to DIR (default: ``<bag folder>/report``):

- ``trajectories.png``: the features and responses against time (Fig. 9/10 style), measured,
  and the mock's true contact when recorded;
- ``planes.png``: the feature path (dx, theta_y) and the response path on the Fig. 6
  segmentation (the normalised plane with the boundaries of eq. 21 and 24);
- ``states.png``: the contact state of each plane (boundary mapping, eq. 21-25) and the
  controller's phase against time;
- ``contact_states.png``: the contact state of each plane by the deviation filter (the history
  of responses and measured features), with its probability, and the mock's true state when
  recorded (its agreement in the summary): the controller's own estimate when the bag holds
  ``fbcc/contact_state_estimate``, else the filter run here (at most 200 updates a second);
- ``summary.json`` and ``summary.md``: the phases with their times, the final features, the
  peak forces, the time in each contact state, the message counts, and whether the bag is
  truncated (also said on stderr).

Exit status 0; 2 on bad input (a missing file, a file that is not mcap, a bag without the
needed topics, a scenario that cannot be found), with one line saying what and no traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.bag.reader import Bag, read_bag
from fbcc_ros.cli import report_states
from fbcc_ros.cli.sim_plots import Series, draw_planes, draw_trajectories
from fbcc_ros.core.contact.model import FEATURE_NAMES, RESPONSE_NAMES, PegHole
from fbcc_ros.core.errors import InputError, command

NEEDED = {"/fbcc/features": "geometry_msgs/msg/PoseStamped",
          "/ft_sensor/compensated": "geometry_msgs/msg/WrenchStamped"}  # fmt: skip


@dataclass
class Session:
    """A recorded session on one time axis (t = 0 at the first command, else the first
    sample): the response per compensated sample with the features measured then."""

    t: np.ndarray  # (T,) [s]
    features: np.ndarray  # (T, 5), the latest measured at each sample
    response: np.ndarray  # (T, 5)
    commands: tuple[np.ndarray, np.ndarray]  # (t, features (C, 5))
    truth: tuple[np.ndarray, np.ndarray, np.ndarray] | None  # (t, features, response)
    phases: list[tuple[float, str]]  # (t, "phase: reason")
    t0: float  # the stamp of t = 0 [s]


def nominal_geometry(bag: Bag, scenario: Path | None) -> PegHole:
    """The controller's nominal pair: ``--scenario``, else the bag's controller parameters."""
    from fbcc_ros.bag.offline import node_parameters
    from fbcc_ros.core.sim import scenario as scenario_io
    from fbcc_ros.pipeline import controller
    from fbcc_ros.pipeline.parameters import resolve

    if scenario is None:
        given = node_parameters(bag.path).get("fbcc_controller", {})
        values = resolve("fbcc_controller", controller.TABLE, given)
        scenario = Path(values["scenario"])
        if "scenario" not in given:
            print(f"fbcc-report: no controller parameters beside the bag; the nominal pair is "
                  f"the controller's default scenario {scenario} (else: --scenario)",
                  file=sys.stderr)  # fmt: skip
    return scenario_io.load(scenario_io.find(str(scenario))).geometry


def session(bag: Bag, nominal: PegHole) -> Session:
    """The bag's samples, decoded and aligned."""
    from fbcc_ros.core.compensation.wrench import response_from_wrench
    from fbcc_ros.core.contact.features import features_from_pose
    from fbcc_ros.ros.cdr import decode_array, decode_string
    from fbcc_ros.ros.convert import pose_from_cdr, wrench_from_cdr

    bag.require(NEEDED)
    r = nominal.peg_radius

    def poses(topic: str) -> tuple[np.ndarray, np.ndarray]:
        rows = [pose_from_cdr(m.data) for m in bag.of(topic)]
        t = np.array([s for s, _ in rows])
        x = np.array([features_from_pose(p.rotation, p.translation, r) for _, p in rows])
        return t, x.reshape(-1, 5)

    t_x, x = poses("/fbcc/features")
    wrenches = [wrench_from_cdr(m.data) for m in bag.of("/ft_sensor/compensated")]
    t = np.array([s for s, _, _ in wrenches])
    acting = nominal.acting_point_in_hole()
    response = np.array([response_from_wrench(w, acting) for _, _, w in wrenches])
    # the features the controller had at each sample: the latest measured at or before it
    order = np.argsort(t_x)
    t_x, x = t_x[order], x[order]
    latest = np.clip(np.searchsorted(t_x, t, side="right") - 1, 0, len(t_x) - 1)
    t_c, commands = poses("/fbcc/command")
    t0 = float(t_c.min()) if t_c.size else float(t.min())
    truth = None
    if bag.counts["/mock_cell/truth"]:
        rows = np.array([decode_array(m.data) for m in bag.of("/mock_cell/truth")])
        truth = (rows[:, 0] - t0, rows[:, 1:6], rows[:, 6:11])
    t_first = min(m.log_time_ns for m in bag.messages) * 1e-9
    # the phase's time: when it was recorded (its first one, latched, before anything else)
    phases = [(max(m.log_time_ns * 1e-9, t_first) - t0, decode_string(m.data))
              for m in bag.of("/fbcc/phase")]  # fmt: skip
    return Session(t - t0, x[latest], response, (t_c - t0, commands), truth, phases, t0)


def summarise(bag: Bag, s: Session, nominal: PegHole) -> dict[str, Any]:
    from fbcc_ros.core.contact.segmentation import response_state

    active = s.t >= 0.0
    xoz, yoz = response_state(s.response[active], s.features[active, 2], nominal)
    shares = {plane: {str(k): round(float(v) / max(int(active.sum()), 1), 4)
                      for k, v in zip(*np.unique(states, return_counts=True), strict=True)}
              for plane, states in (("XOZ", xoz), ("YOZ", yoz))}  # fmt: skip
    force = np.linalg.norm(s.response[active, :3], axis=1) if active.any() else np.zeros(1)
    inserted = [t for t, p in s.phases if p.startswith("inserted")]
    return {
        "bag": str(bag.path),
        "truncated": bag.truncated,
        "messages": {topic: bag.counts[topic] for topic in bag.topics},
        "duration_s": round(float(s.t[-1] - s.t[0]), 4),
        "phases": [{"t": round(t, 4), "phase": p} for t, p in s.phases],
        "final_phase": s.phases[-1][1] if s.phases else "",
        "insertion_time_s": round(inserted[0], 4) if inserted else None,
        "final_features": dict(zip(FEATURE_NAMES, s.features[-1].tolist(), strict=True)),
        "final_response": dict(zip(RESPONSE_NAMES, s.response[-1].tolist(), strict=True)),
        "peak_force_n": round(float(force.max()), 4),
        "peak_fz_n": round(float(s.response[active, 2].max(initial=0.0)), 4),
        "contact_state_share": shares,
        "commands": int(s.commands[0].size),
        "samples": int(s.t.size),
    }


def draw_states(s: Session, nominal: PegHole, path: Path) -> Path:
    """The contact state of each plane and the controller's phase against time."""
    from fbcc_ros.core.contact.segmentation import STATES, response_state
    from fbcc_ros.core.control.phase import Phase

    xoz, yoz = response_state(s.response, s.features[:, 2], nominal)
    fig, axes = plt.subplots(3, 1, figsize=(12, 6.5), sharex=True,
                             gridspec_kw={"height_ratios": [3, 3, 1.4]})  # fmt: skip
    for ax, states, plane in ((axes[0], xoz, "W_XOZ"), (axes[1], yoz, "W_YOZ")):
        ax.plot(s.t, [STATES.index(str(x)) for x in states], ".", ms=2)
        ax.set_yticks(range(len(STATES)), STATES)
        ax.set_ylabel(f"{plane} state")
        ax.grid(alpha=0.3)
    names = [p.split(":")[0] for _, p in s.phases]
    for (t, _), (t_next, _), name in zip(s.phases, [*s.phases[1:], (s.t[-1], "")], names,
                                         strict=True):  # fmt: skip
        colour = [p.value for p in Phase].index(name) if name in set(Phase) else len(Phase)
        axes[2].axvspan(t, t_next, alpha=0.3, color=f"C{colour % 10}")
        axes[2].text(t, 0.5, f" {name}", va="center", fontsize=8)
    axes[2].set_yticks([])
    axes[2].set_ylabel("phase")
    axes[2].set_xlabel("t [s] (0: the first command)")
    axes[0].set_title("Contact state by boundary mapping (eq. 21-25), and the controller's phase")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def markdown(summary: dict[str, Any]) -> str:
    lines = [f"# Session report: `{summary['bag']}`", ""]
    if summary["truncated"]:
        lines += [f"**The bag is not whole** ({summary['truncated']}): this report covers what "
                  "it holds; `fbcc-recover` writes it whole.", ""]  # fmt: skip
    lines += [
        f"- duration {summary['duration_s']} s, {summary['samples']} compensated samples, "
        f"{summary['commands']} commands",
        f"- final phase **{summary['final_phase'] or 'unknown'}**; inserted at "
        f"{summary['insertion_time_s']} s" if summary["insertion_time_s"] is not None else
        f"- final phase **{summary['final_phase'] or 'unknown'}**; not inserted",
        f"- peak |F| {summary['peak_force_n']} N, peak Fz {summary['peak_fz_n']} N",
        "", "| feature | final | | response | final |", "|---|---|---|---|---|",
    ]  # fmt: skip
    finals = zip(summary["final_features"].items(), summary["final_response"].items(), strict=True)
    for (fname, fval), (rname, rval) in finals:
        lines.append(f"| {fname} | {fval:.4g} | | {rname} | {rval:.4g} |")
    lines += ["", "Phases:", ""]
    lines += [f"- t = {p['t']} s: {p['phase']}" for p in summary["phases"]]
    lines += ["", "Share of the insertion in each contact state (boundary mapping):", ""]
    for plane, shares in summary["contact_state_share"].items():
        lines.append(f"- {plane}: " + ", ".join(f"{k} {v:.1%}" for k, v in shares.items()))
    lines += ["", "Messages per topic:", ""]
    lines += [f"- `{t}`: {n}" for t, n in summary["messages"].items()]
    lines += ["", "![trajectories](trajectories.png)", "![planes](planes.png)",
              "![states](states.png)", ""]  # fmt: skip
    if "contact_state_estimate" in summary:
        states = summary["contact_state_estimate"]
        lines.append(f"Contact state by the {states['source']}: {states['updates']} updates.")
        for method, planes in (states["agreement_with_truth"] or {}).items():
            lines.append(f"- {method}: the mock's true state "
                         + ", ".join(f"{k} {v:.0%}" for k, v in planes.items()))
        lines += ["", "![contact states](contact_states.png)", ""]
    if "contact_estimate" in summary:
        est = summary["contact_estimate"]
        lines += ["Last contact identification (robust law): "
                  + ", ".join(f"{k} {v:.3g}" for k, v in est.items()), "",
                  "![estimate](estimate.png)", ""]  # fmt: skip
    return "\n".join(lines)


def contact_estimate(bag: Bag, t0: float) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """The robust law's identification (``fbcc/contact_estimate``): times [s from t0] and each
    field's values, named by the messages' layout (a bag recorded before a field existed lacks
    it; an unlabelled one is read in ``identification.ESTIMATE_FIELDS`` order); None when the
    bag has none."""
    from fbcc_ros.core.control.identification import ESTIMATE_FIELDS
    from fbcc_ros.ros.cdr import decode_labelled_array

    if not bag.counts.get("/fbcc/contact_estimate"):
        return None
    messages = [decode_labelled_array(m.data) for m in bag.of("/fbcc/contact_estimate")]
    labels = messages[0][0]
    names = labels[0].split() if labels else ["stamp", *ESTIMATE_FIELDS]
    if any(len(data) != len(names) for _, data in messages):
        raise InputError("/fbcc/contact_estimate", f"{len(names)} fields in its layout",
                         "messages with one value per field")  # fmt: skip
    columns = dict(zip(names, np.array([data for _, data in messages]).T, strict=True))
    return columns.pop("stamp") - t0, columns


def draw_estimate(t: np.ndarray, est: dict[str, np.ndarray], path: Path) -> Path:
    """The identified stiffness of the four rows (log), the friction bound and the lever's
    friction, the guard's trips."""
    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    for row, unit in (("dx", "N/m"), ("dy", "N/m")):
        a1.semilogy(t, est[f"k_{row}"], label=f"k {row} [{unit}]")
    for row in ("theta_x", "theta_y"):
        a2.semilogy(t, est[f"k_{row}"], label=f"k {row} [N/rad]")
    a3.plot(t, est["friction"], label="friction (upper bound)")
    if "lever_friction" in est:
        a3.plot(t, est["lever_friction"], label="friction in the lever (eq. 24)")
    a3.step(t, est["guard_trips"] / 10.0, where="post", label="guard trips / 10")
    a3.set(xlabel="t [s]")
    for ax in (a1, a2, a3):
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8, loc="upper left")
    a1.set_title("contact identification (robust FBCC)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def report(bag_path: Path, out: Path | None, scenario: Path | None) -> dict[str, Any]:
    bag = read_bag(bag_path)
    nominal = nominal_geometry(bag, scenario)
    s = session(bag, nominal)
    out = out or bag.path.parent / "report"
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("--out", str(out), f"a folder ({exc.strerror})") from None
    series = [Series("measured", s.t, s.features, s.response, nominal)]
    if s.truth is not None:
        series.append(Series("true (mock)", *s.truth, nominal))
    draw_trajectories(series, out / "trajectories.png")
    draw_planes(series, out / "planes.png")
    draw_states(s, nominal, out / "states.png")
    summary = summarise(bag, s, nominal)
    states = report_states.recorded_states(bag, s, nominal) or report_states.estimate_states(
        s, nominal)
    if states is not None:
        report_states.draw_state_estimate(states, out / "contact_states.png")
        summary["contact_state_estimate"] = {
            "source": states["source"], "updates": len(states["t"]),
            "every_nth_sample": states["every"],
            "agreement_with_truth": report_states.agreement(states)}  # fmt: skip
    estimate = contact_estimate(bag, s.t0)
    if estimate is not None:
        draw_estimate(*estimate, out / "estimate.png")
        summary["contact_estimate"] = {k: float(v[-1]) for k, v in estimate[1].items()}
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "summary.md").write_text(markdown(summary))
    summary["out"] = str(out)
    return summary


@command("fbcc-report")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fbcc-report", description=__doc__.splitlines()[0])
    parser.add_argument("bag", type=Path, help="bag folder or .mcap file")
    parser.add_argument("--out", type=Path, default=None, help="default: <bag folder>/report")
    parser.add_argument(
        "--scenario", type=Path, default=None, help="the nominal pair (default: the bag's)"
    )
    args = parser.parse_args(argv)
    summary = report(args.bag, args.out, args.scenario)
    if summary["truncated"]:
        print(f"fbcc-report: the bag is NOT WHOLE ({summary['truncated']}); the report covers "
              "what it holds (fbcc-recover writes it whole)", file=sys.stderr)  # fmt: skip
    print(f"{summary['final_phase'] or 'no phase recorded'}; {summary['duration_s']} s, "
          f"peak Fz {summary['peak_fz_n']} N; final depth "
          f"{summary['final_features']['l'] * 1e3:.3f} mm; wrote {summary['out']}/")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
