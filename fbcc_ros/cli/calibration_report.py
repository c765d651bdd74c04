"""What fbcc-calibrate reports of a fit: the warnings of an implausible one, the residual plot,
the per-pose table of a bag's held poses, and the report written on stdout and into the YAML
the dynamic_compensation node loads."""

from __future__ import annotations

import argparse
import datetime
from pathlib import Path

import numpy as np

from fbcc_ros.core.compensation import calibration_data as cd
from fbcc_ros.core.compensation import calibration_poses as cp
from fbcc_ros.core.compensation.calibration_file import calibration_yaml
from fbcc_ros.core.compensation.payload import Calibration, Motion, payload_wrench

#: The columns of a raw reading in {S} [N, N m].
WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")

#: Beyond these the fit is no payload of an arm's wrist (the arms modelled carry 3-14 kg): the
#: data's units are the likely cause (forces in mN, torques in N mm).
PLAUSIBLE_MASS_KG = 50.0
PLAUSIBLE_COM_M = 0.5


def implausible(fit: Calibration) -> list[str]:
    """What in a fit no wrist payload would give, and the likely cause."""
    out = []
    if fit.payload.mass > PLAUSIBLE_MASS_KG:
        out.append(f"mass {fit.payload.mass:.4g} kg is more than {PLAUSIBLE_MASS_KG:g} kg: "
                   "are the forces in N (not mN)?")  # fmt: skip
    com = float(np.linalg.norm(fit.payload.com))
    if com > PLAUSIBLE_COM_M:
        out.append(f"centre of mass {com:.4g} m from the sensor is more than {PLAUSIBLE_COM_M:g} m"
                   ": are the torques in N m (not N mm) and the forces in N?")  # fmt: skip
    return out


def plot(fit: Calibration, motions: list[Motion], wrenches: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model = np.array([payload_wrench(fit.payload, m) for m in motions]) + fit.bias
    residual = wrenches - model
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for i, name in enumerate(WRENCH[:3]):
        top.plot(residual[:, i], ".-", label=name)
    for i, name in enumerate(WRENCH[3:]):
        bottom.plot(residual[:, 3 + i] * 1e3, ".-", label=name)
    top.set_ylabel("force residual [N]")
    bottom.set_ylabel("torque residual [mN m]")
    bottom.set_xlabel("sample")
    top.set_title(
        f"calibration residual: rms {fit.residual_rms[0]:.3g} N, "
        f"{fit.residual_rms[1] * 1e3:.3g} mN m; condition {fit.condition:.3g}"
    )
    top.legend(ncol=3, fontsize=8)
    bottom.legend(ncol=3, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write(args: argparse.Namespace, fit: Calibration, motions: list[Motion],
           wrenches: np.ndarray, source: str, lines: tuple[str, ...] = (),
           after: str = "") -> None:  # fmt: skip
    """The report on stdout and in the YAML's header (``lines`` after its first), then
    ``after`` on stdout only."""
    mode = "dynamic" if args.dynamic else "static"
    p = fit.payload
    report = "\n".join([
        f"fbcc-calibrate {mode} fit of {source}, {datetime.date.today().isoformat()}",
        *lines,
        f"mass {p.mass:.4f} kg, centre of mass {np.round(p.com, 5).tolist()} m",
        f"bias {np.round(fit.bias, 4).tolist()} N, N m",
        f"residual rms {fit.residual_rms[0]:.4g} N, {fit.residual_rms[1]:.4g} N m; "
        f"condition number {fit.condition:.3g}",
    ])  # fmt: skip
    if args.dynamic:
        report += f"\ninertia about the centre of mass {np.round(p.inertia, 6).tolist()} kg m^2"
    for warning in implausible(fit):
        report += f"\nWARNING: {warning}"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(calibration_yaml(fit, report))
    if args.plot:
        plot(fit, motions, wrenches, args.plot)
    print(report)
    if after:
        print(after)
    print(f"wrote {args.out}")



def poses_table(samples: cd.StaticSamples, gravity: np.ndarray, result: cp.Excitation,
                 start: float, fit: Calibration | None = None) -> str:  # fmt: skip
    """One line per pose: when (from ``start``), how many readings, gravity's direction, what
    it adds to the condition number, and (after a fit) its residual beside its noise."""
    head = f"{'pose':>4}  {'averaged [s]':>13}  {'readings':>8}  {'gravity in {S} [g]':>20}  "
    head += f"{'condition without':<22}"
    if fit is not None:
        head += f"{'residual F [N]':>14}  {'T [N m]':>8}  {'s.e. F [N]':>10}  {'T [N m]':>8}"
    out = [head.rstrip()]
    for k, (dwell, g) in enumerate(zip(samples.dwells, gravity, strict=True)):
        u = g / np.linalg.norm(g)
        w0, w1 = dwell.window[0] - start, dwell.window[1] - start
        gravity_text = "[" + " ".join(f"{round(x, 2) + 0.0:+.2f}" for x in u) + "]"
        line = (f"{k + 1:>4}  {w0:>6.2f}-{w1:<6.2f}  {dwell.readings:>8}  {gravity_text:>20}  "
                f"{f'{result.without[k]:.3g} ({result.roles[k]})':<22}")  # fmt: skip
        if fit is not None:
            residual = dwell.wrench - payload_wrench(fit.payload, Motion(g)) - fit.bias
            error = dwell.standard_error
            line += (f"{np.linalg.norm(residual[:3]):>14.3g}  "
                     f"{np.linalg.norm(residual[3:]):>8.3g}  {np.linalg.norm(error[:3]):>10.3g}"
                     f"  {np.linalg.norm(error[3:]):>8.3g}")  # fmt: skip
        out.append(line.rstrip())
    out.append(f"condition number over all {len(gravity)}: {result.condition:.3g} (without a "
               f"'needed' pose it grows {cp.NEEDED_RATIO:g}x or more; without a 'redundant' "
               f"one under {(cp.REDUNDANT_RATIO - 1) * 100:g} %)")  # fmt: skip
    return "\n".join(out)


