"""fbcc-maps: contact responses of the paper's pairs and the state maps of Fig. 5 and Fig. 6.

Writes to --out:
  feature_states.png   Fig. 5: the states in (dx, theta_y) at several depths, both fits, with the
                       model's own no-contact region (Fz = 0) outlined against eq. (15)
  response_states.png  Fig. 6: the boundaries in (Fx/Fz, My/(R Fz)) at several depths, with model
                       responses of random features scattered on them, coloured by true state
  responses.csv        the table printed on stdout: features, responses and both state judgements
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap

from fbcc_ros.cli.common import out_dir
from fbcc_ros.core.contact.model import FEATURE_NAMES, RESPONSE_NAMES, PegHole
from fbcc_ros.core.contact.segmentation import (
    STATES,
    feature_state,
    normalised_coordinates,
    response_state,
    tilt_boundary_angle,
)
from fbcc_ros.core.errors import command
from fbcc_ros.core.paper import paper_pair

DEPTHS = (2e-3, 5e-3, 10e-3)
COLOURS = {
    "P0": "#ffffff",
    "P1": "#7f7f7f",
    "P-1": "#bcbcbc",
    "D0": "#d62728",
    "D1": "#ff7f0e",
    "D-1": "#e377c2",
    "D^0": "#1f77b4",
    "D^1": "#17becf",
    "D^-1": "#2ca02c",
}
#: Demo configurations: (dx, dy, l, theta_x, theta_y) in mm and degrees, as a user would type them.
DEMO_FEATURES_MM_DEG = (
    (0.0, 0.0, 5.0, 0.0, 0.0),
    (0.005, 0.0, 5.0, 0.0, 0.0),
    (0.05, 0.0, 5.0, 0.0, 0.0),
    (0.05, 0.0, 5.0, 0.0, 2.0),
    (0.05, 0.0, 5.0, 0.0, -2.0),
    (-0.05, 0.0, 10.0, 0.0, 2.0),
    (0.0, 0.05, 5.0, -2.0, 0.0),
    (0.05, 0.05, 10.0, 1.0, 1.0),
)


def _to_si(row_mm_deg: tuple[float, ...]) -> np.ndarray:
    dx, dy, l, thx, thy = row_mm_deg
    return np.array([dx * 1e-3, dy * 1e-3, l * 1e-3, math.radians(thx), math.radians(thy)])


def response_table(out: Path) -> list[dict[str, object]]:
    """Responses of the demo configurations for both fits, printed and written as CSV."""
    rows: list[dict[str, object]] = []
    for fit in ("clearance", "interference"):
        ph = paper_pair(fit)
        feats = np.array([_to_si(r) for r in DEMO_FEATURES_MM_DEG])
        resp = ph.response(feats)
        f_xoz, f_yoz = feature_state(feats, ph)
        r_xoz, r_yoz = response_state(resp, feats[:, 2], ph)
        for i, raw in enumerate(DEMO_FEATURES_MM_DEG):
            row: dict[str, object] = {"fit": fit}
            row.update({f"{n}[mm|deg]": v for n, v in zip(FEATURE_NAMES, raw, strict=True)})
            row.update(
                {
                    f"{n}[N|Nm]": round(float(v), 4)
                    for n, v in zip(RESPONSE_NAMES, resp[i], strict=True)
                }
            )
            row.update(
                feature_xoz=f_xoz[i],
                feature_yoz=f_yoz[i],
                response_xoz=r_xoz[i],
                response_yoz=r_yoz[i],
            )
            rows.append(row)
    with open(out / "responses.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(
        f"{'fit':12s} {'dx':>6s} {'dy':>6s} {'l':>5s} {'thx':>5s} {'thy':>5s}   "
        f"{'Fx':>8s} {'Fy':>8s} {'Fz':>8s} {'Mx':>8s} {'My':>8s}   feature -> response state"
    )
    print(
        f"{'':12s} {'mm':>6s} {'mm':>6s} {'mm':>5s} {'deg':>5s} {'deg':>5s}   "
        f"{'N':>8s} {'N':>8s} {'N':>8s} {'N·m':>8s} {'N·m':>8s}"
    )
    for row in rows:
        vals = list(row.values())
        print(
            f"{vals[0]:12s} "
            + " ".join(f"{v:6.3f}" if i < 2 else f"{v:5.1f}" for i, v in enumerate(vals[1:6]))
            + "   "
            + " ".join(f"{v:8.3f}" for v in vals[6:11])
            + f"   XOZ {vals[11]}->{vals[13]}, YOZ {vals[12]}->{vals[14]}"
        )
    return rows


def _save(fig: plt.Figure, path: Path, rect: tuple[float, float, float, float]) -> Path:
    fig.tight_layout(rect=rect)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def draw_feature_states(out: Path) -> Path:
    """Fig. 5: states in (dx, theta_y) per depth and fit, zoomed so that P0 is visible."""
    states = list(STATES)
    cmap = ListedColormap([COLOURS[s] for s in states])
    dx = np.linspace(-20e-6, 20e-6, 241)
    th = np.linspace(-math.radians(0.3), math.radians(0.3), 241)
    DX, TH = np.meshgrid(dx, th)
    fig, axes = plt.subplots(2, len(DEPTHS), figsize=(4.2 * len(DEPTHS), 8), squeeze=False)
    for i, fit in enumerate(("clearance", "interference")):
        ph = paper_pair(fit)
        for j, depth in enumerate(DEPTHS):
            ax = axes[i][j]
            f = np.column_stack(
                [
                    DX.ravel(),
                    np.zeros(DX.size),
                    np.full(DX.size, depth),
                    np.zeros(DX.size),
                    TH.ravel(),
                ]
            )
            xoz, _ = feature_state(f, ph)
            idx = np.array([states.index(s) for s in xoz]).reshape(DX.shape)
            ax.pcolormesh(
                DX * 1e6,
                np.degrees(TH),
                idx,
                cmap=cmap,
                vmin=-0.5,
                vmax=len(states) - 0.5,
                shading="auto",
            )
            fz = ph.response(f)[:, 2].reshape(DX.shape)
            ax.contour(
                DX * 1e6,
                np.degrees(TH),
                fz,
                levels=[1e-3],
                colors="k",
                linestyles="--",
                linewidths=1.0,
            )
            ax.axhline(0, color="k", lw=0.5)
            ax.axvline(0, color="k", lw=0.5)
            ax.set_title(f"{fit}, l = {depth * 1e3:.0f} mm")
            ax.set_xlabel("dx [µm]")
            ax.set_ylabel("θy [deg]")
    handles: list[Any] = [
        plt.Rectangle((0, 0), 1, 1, fc=COLOURS[s], ec="k", lw=0.3) for s in states
    ]
    handles.append(plt.Line2D([], [], color="k", ls="--"))
    fig.legend(
        handles, [*states, "model: Fz = 0 boundary"], loc="lower center", ncol=10, fontsize=8
    )
    fig.suptitle(
        "Fig. 5 — contact states in V_XOZ (eq. 15-17); dashed: the contact model's "
        "own no-contact boundary"
    )
    return _save(fig, out / "feature_states.png", rect=(0, 0.05, 1, 0.97))


def draw_response_states(out: Path, n: int = 600, seed: int = 0) -> Path:
    """Fig. 6: boundaries in the normalised plane, model responses coloured by true state."""
    rng = np.random.default_rng(seed)
    fig, axes = plt.subplots(2, len(DEPTHS), figsize=(4.6 * len(DEPTHS), 9), squeeze=False)
    tilt = math.radians(2.0)
    for i, fit in enumerate(("clearance", "interference")):
        ph: PegHole = paper_pair(fit)
        for j, depth in enumerate(DEPTHS):
            ax = axes[i][j]
            f = np.column_stack(
                [
                    rng.uniform(-1e-4, 1e-4, n),
                    np.zeros(n),
                    np.full(n, depth),
                    np.zeros(n),
                    rng.uniform(-tilt, tilt, n),
                ]
            )
            resp = ph.response(f)
            keep = resp[:, 2] > 0.05
            u, _, _, _ = normalised_coordinates(resp[keep], depth, ph)
            v = resp[keep, 4] / (ph.hole_radius * resp[keep, 2])
            truth, _ = feature_state(f[keep], ph)
            for s in STATES:
                m = np.asarray(truth == s)
                if m.any():
                    ax.scatter(u[m], v[m], s=6, color=COLOURS[s] if s != "P0" else "k", label=s)
            x = np.linspace(-3.5, 3.5, 2)
            slope = math.tan(float(tilt_boundary_angle(depth, ph)))
            ax.plot(x, slope * x, "k-", lw=1.0, label=f"θy = 0 image, slope {slope:.2f}")
            ax.axvline(0, color="k", lw=1.0)
            ax.plot([0], [0], "ko", ms=5)
            ax.set_xlim(-3.5, 3.5)
            ax.set_ylim(-12, 12)
            ax.set_xlabel("Fx / Fz")
            ax.set_ylabel("My / (R Fz)")
            ax.set_title(f"{fit}, l = {depth * 1e3:.0f} mm")
            ax.legend(fontsize=7, markerscale=2.5, loc="upper left")
    fig.suptitle(
        "Fig. 6 — boundary mapping in W_XOZ: dx = 0 ↦ Fx = 0 (eq. 21), θy = 0 ↦ "
        "tilted line (eq. 24), P0 at the origin (eq. 25)\ndots: model responses of "
        "random (dx, θy), coloured by their true state"
    )
    return _save(fig, out / "response_states.png", rect=(0, 0, 1, 0.96))


@command("fbcc-maps")
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fbcc-maps", description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/maps", help="output folder (created)")
    args = parser.parse_args(argv)
    out = out_dir(parser, args.out)
    print(
        "Contact responses of the paper's pairs (Section IV: R 5.05 / r 5.04 mm clearance, "
        "R 5.03 / r 5.04 mm interference; L 10 mm)"
    )
    response_table(out)
    for path in (draw_feature_states(out), draw_response_states(out)):
        print(f"wrote {path}")
    print(f"wrote {out / 'responses.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
