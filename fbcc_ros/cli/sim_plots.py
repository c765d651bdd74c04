"""Figures of assemblies, simulated or recorded, in the style of the paper's Fig. 8-10.

``draw_trajectories``: the features of V_XOZ (dx, theta_y, l) and the responses of W_XOZ
(Fx, My, Fz) against time, and the same for YOZ, every run on the same axes.
``draw_planes``: each run as a path in the feature plane (dx, theta_y) and in the normalised
response plane of Fig. 6 (Fx/Fz, My/(R Fz)) with the boundaries of eq. 21 and 24.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import tilt_boundary_angle
from fbcc_ros.core.sim.simulation import SimResult

_MM, _DEG = 1e3, 180.0 / np.pi


@dataclass
class Series:
    """One run to draw: features and responses, (T, 5) each, at times t (T,) [s]."""

    name: str
    t: np.ndarray
    features: np.ndarray
    response: np.ndarray
    geometry: PegHole

    @classmethod
    def simulated(cls, name: str, res: SimResult) -> Series:
        tr = res.trajectory
        return cls(name, tr.t, tr.features[:, 0], tr.response[:, 0], res.scenario.geometry)


def draw_trajectories(runs: Sequence[Series], path: Path) -> Path:
    """Features and responses against time for every run (Fig. 8/9 style)."""
    panels = (  # XOZ on top, YOZ below; l and Fz once each
        ("features", 0, _MM * 1e3, "dx [µm]"), ("features", 4, _DEG, "θy [°]"),
        ("features", 2, _MM, "l [mm]"), ("response", 0, 1.0, "Fx [N]"),
        ("response", 4, 1.0, "My [N·m]"),
        ("features", 1, _MM * 1e3, "dy [µm]"), ("features", 3, _DEG, "θx [°]"),
        ("response", 2, 1.0, "Fz [N]"), ("response", 1, 1.0, "Fy [N]"),
        ("response", 3, 1.0, "Mx [N·m]"),
    )  # fmt: skip
    fig, axes = plt.subplots(2, 5, figsize=(17, 6.5), sharex=True)
    for ax, (kind, col, scale, label) in zip(axes.flat, panels, strict=True):
        for run in runs:
            ax.plot(run.t, getattr(run, kind)[:, col] * scale, lw=1.2, label=run.name)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].set_title("V_XOZ: features")
    axes[0, 3].set_title("W_XOZ: responses")
    axes[1, 0].set_title("V_YOZ")
    axes[1, 3].set_title("W_YOZ")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def draw_planes(runs: Sequence[Series], path: Path) -> Path:
    """Paths in the feature plane V_XOZ and in the normalised response plane W_XOZ (Fig. 10)."""
    fig, (ax_v, ax_w) = plt.subplots(1, 2, figsize=(12, 5))
    lim = 0.0
    for run in runs:
        name, ph, x, w = run.name, run.geometry, run.features, run.response
        ax_v.plot(x[:, 0] * _MM * 1e3, x[:, 4] * _DEG, lw=1.2, label=name)
        ax_v.plot(x[0, 0] * _MM * 1e3, x[0, 4] * _DEG, "o", color=ax_v.lines[-1].get_color())
        # Fig. 6 plane: u = Fx/Fz, v = My/(R Fz); only where the peg clearly touches
        contact = w[:, 2] > 0.05 * max(float(w[:, 2].max()), 1e-9)
        fz = np.where(contact, w[:, 2], np.nan)
        u, v = w[:, 0] / fz, w[:, 4] / (ph.hole_radius * fz)
        ax_w.plot(u[contact], v[contact], lw=1.0, label=name)
        lim = max(lim, float(np.nanmax(np.abs(u[contact]), initial=0.0)))
    ph = runs[0].geometry
    lim = max(lim, 0.5)
    for depth, style in ((0.0, ":"), (ph.hole_depth, "--")):
        slope = np.tan(tilt_boundary_angle(depth, ph))
        ax_w.plot([-lim, lim], [-lim * slope, lim * slope], "k" + style, lw=0.8,
                  label=f"θy = 0 (eq. 24), l = {depth * _MM:g} mm")  # fmt: skip
    ax_w.axvline(0.0, color="k", lw=0.8, label="dx = 0 (eq. 21)")
    ax_v.axhline(0.0, color="k", lw=0.8)
    ax_v.axvline(0.0, color="k", lw=0.8)
    ax_v.set(xlabel="dx [µm]", ylabel="θy [°]", title="V_XOZ: feature paths (o = start)")
    ax_w.set(xlabel="Fx / Fz", ylabel="My / (R Fz)", title="W_XOZ: response paths (Fig. 6 plane)")
    for ax in (ax_v, ax_w):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
