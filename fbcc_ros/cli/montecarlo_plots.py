"""``fbcc-montecarlo``'s figures: the metrics' histograms per law, success, peak Fz and
insertion time against the drawn stiffness, and the friction the robust law's lever measured
against each part's μ."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.core.sim.montecarlo import Trials
from fbcc_ros.core.sim.simulation import Outcome

#: Metrics summarised by percentiles: (name, scale to the printed unit, unit).
METRICS = (
    ("peak_fz", 1.0, "N"),
    ("residual_force", 1.0, "N"),
    ("residual_moment", 1.0, "N·m"),
    ("tilt_overshoot", 180 / math.pi, "deg"),
    ("tilt_misadjustment", 180 / math.pi, "deg"),
    ("insertion_time", 1.0, "s"),
)


def draw(results: dict[str, Outcome], path: Path) -> None:
    fig, axes = plt.subplots(1, len(METRICS), figsize=(4 * len(METRICS), 3.6))
    for ax, (name, scale, unit) in zip(axes, METRICS, strict=True):
        for law, o in results.items():
            v = getattr(o, name) * scale
            v = v[np.isfinite(v)]
            rate = o.success.mean()
            ax.hist(v, bins=40, alpha=0.6, label=f"{law} ({rate:.1%} success)")
        ax.set(xlabel=f"{name} [{unit}]", ylabel="trials")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_stiffness(trials: Trials, results: dict[str, Outcome],
                   missed_by_law: dict[str, list[list[str]]], deadline: float,
                   path: Path) -> None:  # fmt: skip
    """Success rate per ninth of the k range (log), and every trial's peak Fz and insertion
    time against k, with the time goal ``deadline`` [s]; a trial that missed a goal
    (:func:`missed_goals`) is ringed in the time panel, so the study's tail is seen where it
    lies."""
    k = np.array([g.stiffness for g in trials.geometries])
    edges = np.geomspace(k.min(), k.max() * (1 + 1e-9), 10)
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(16, 4))
    for law, o in results.items():
        idx = np.clip(np.digitize(k, edges) - 1, 0, len(edges) - 2)
        rate = [o.success[idx == b].mean() if (idx == b).any() else np.nan
                for b in range(len(edges) - 1)]  # fmt: skip
        a1.semilogx(np.sqrt(edges[:-1] * edges[1:]), np.array(rate) * 100, "o-", label=law)
        a2.loglog(k[o.success], o.peak_fz[o.success], ".", ms=2, label=f"{law}: assembled")
        a2.loglog(k[~o.success], o.peak_fz[~o.success], "x", ms=4, label=f"{law}: failed")
        missed = np.array([bool(why) for why in missed_by_law[law]])
        (dots,) = a3.semilogx(k[o.success], o.insertion_time[o.success], ".", ms=2,
                              label=f"{law}: assembled")  # fmt: skip
        late = missed & o.success
        a3.semilogx(k[late], o.insertion_time[late], "o", mfc="none", ms=7,
                    color=dots.get_color(), label=f"{law}: missed a goal ({int(missed.sum())})")
    a3.axhline(deadline, color="k", lw=0.8, ls="--", label=f"goal: {deadline:g} s")
    a1.set(xlabel="contact stiffness k [Pa]", ylabel="assembled [%]", ylim=(0, 101))
    a2.set(xlabel="contact stiffness k [Pa]", ylabel="peak Fz [N]")
    a3.set(xlabel="contact stiffness k [Pa]", ylabel="insertion time [s]")
    for ax in (a1, a2, a3):
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_friction(trials: Trials, results: dict[str, Outcome], path: Path) -> None:
    """The friction the lever measured against each part's μ, per law that measures one;
    nothing is drawn when none did."""
    mu = np.array([g.friction for g in trials.geometries])
    measuring = {law: o for law, o in results.items() if np.isfinite(o.friction_estimate).any()}
    if not measuring:
        return
    fig, ax = plt.subplots(figsize=(5.5, 5))
    for law, o in measuring.items():
        ok = np.isfinite(o.friction_estimate)
        ax.plot(mu[ok], o.friction_estimate[ok], ".", ms=3,
                label=f"{law}: measured on {int(ok.sum())}/{len(ok)}")  # fmt: skip
    ax.plot([mu.min(), mu.max()], [mu.min(), mu.max()], "k--", lw=0.8, label="the part's μ")
    ax.set(xlabel="the part's friction μ", ylabel="friction in the lever (eq. 24), at the end")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
