"""fbcc-report's contact states (:mod:`fbcc_ros.cli.report`): the deviation filter's state per
plane along a session, as the controller published it (``fbcc/contact_state_estimate``) or run
over the bag's measured features and responses, beside boundary mapping and the mock's true
state."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fbcc_ros.bag.reader import Bag
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import STATES, feature_state, response_state

if TYPE_CHECKING:
    from fbcc_ros.cli.report import Session

#: The controller's contact-state estimates in a bag (fbcc_ros.ros.topics.CONTACT_STATE_ESTIMATE).
RECORDED = "/fbcc/contact_state_estimate"
#: The rate the report runs the deviation filter at, at most [Hz] (every n-th sample).
STATE_RATE_HZ = 200.0


def estimate_states(s: Session, nominal: PegHole) -> dict[str, Any] | None:
    """The contact state along the session by the deviation filter run here
    (:func:`~fbcc_ros.core.control.deviation_filter.along`, from the first command), with
    :func:`annotated`'s. None when the session never touched."""
    from fbcc_ros.core.control.deviation_filter import along

    active = np.flatnonzero(s.t >= 0.0)
    if len(active) < 2:
        return None
    rate = 1.0 / float(np.median(np.diff(s.t[active])))
    every = max(1, round(rate / STATE_RATE_HZ))
    rows, p = along(s.features[active], s.response[active], nominal, every)
    if not len(rows):
        return None
    return annotated(s, nominal, active[rows], p, "deviation filter, run by the report", every)


def recorded_states(bag: Bag, s: Session, nominal: PegHole) -> dict[str, Any] | None:
    """The controller's own contact-state estimates (:data:`RECORDED`: the stamp of the sample
    each follows, then P(state) of XOZ and YOZ), with :func:`annotated`'s at the session's
    sample of that stamp. None when the bag holds none."""
    from fbcc_ros.ros.cdr import decode_array

    if not bag.counts.get(RECORDED):
        return None
    data = np.array([decode_array(m.data) for m in bag.of(RECORDED)])
    data = data[np.argsort(data[:, 0], kind="stable")]
    rows = np.clip(np.searchsorted(s.t, data[:, 0] - s.t0), 0, len(s.t) - 1)
    p = data[:, 1:].reshape(len(data), 2, len(STATES))
    rate = 1.0 / float(np.median(np.diff(s.t))) if len(s.t) > 1 else 0.0
    every = round(rate * float(np.median(np.diff(data[:, 0])))) if len(data) > 1 else 1
    return annotated(s, nominal, rows, p, "deviation filter, the controller's", every)


def annotated(s: Session, nominal: PegHole, rows: np.ndarray, p: np.ndarray, source: str,
              every: int) -> dict[str, Any]:  # fmt: skip
    """P(state) ``p`` (K, 2, 9) at the session's samples ``rows`` with boundary mapping's state
    there and, when the truth was recorded, the mock's true state (its true features, segmented
    with the nominal radii; -1 above the hole, where there is no state to name)."""
    t = s.t[rows]
    mapped = np.column_stack(response_state(s.response[rows],
                                            np.maximum(s.features[rows, 2], 0.0),
                                            nominal))  # fmt: skip
    out: dict[str, Any] = {"t": t, "p": p, "every": every, "truth": None, "source": source,
                           "mapped": np.vectorize(STATES.index)(mapped)}  # fmt: skip
    if s.truth is not None:
        t_true, x_true, _ = s.truth
        at = np.clip(np.searchsorted(t_true, t, side="right") - 1, 0, len(t_true) - 1)
        x = x_true[at]
        xoz, yoz = feature_state(np.where(x[:, 2:3] > 0, x, 0.0), nominal)
        truth = np.column_stack([np.vectorize(STATES.index)(xoz),
                                 np.vectorize(STATES.index)(yoz)])  # fmt: skip
        out["truth"] = np.where(x[:, 2:3] > 0, truth, -1)
    return out


def agreement(est: dict[str, Any]) -> dict[str, dict[str, float]] | None:
    """Per method and plane, the share of the updates in the hole whose state is the true one."""
    if est["truth"] is None or not (est["truth"] >= 0).any():
        return None
    inside = est["truth"][:, 0] >= 0
    named = {"deviation filter": est["p"].argmax(axis=2), "boundary mapping": est["mapped"]}
    return {method: {plane: round(float((n[inside, i] == est["truth"][inside, i]).mean()), 4)
                     for i, plane in enumerate(("XOZ", "YOZ"))}
            for method, n in named.items()}  # fmt: skip


def draw_state_estimate(est: dict[str, Any], path: Path) -> Path:
    """Per plane the most probable state (coloured by its probability) and the true one."""
    fig, axes = plt.subplots(2, 1, figsize=(12, 6), sharex=True)
    named, p = est["p"].argmax(axis=2), est["p"].max(axis=2)
    for plane, (ax, name) in enumerate(zip(axes, ("XOZ", "YOZ"), strict=True)):
        if est["truth"] is not None:
            truth = np.where(est["truth"][:, plane] >= 0, est["truth"][:, plane], np.nan)
            ax.step(est["t"], truth, where="post", color="0.6", lw=3, label="true (mock)")
        dots = ax.scatter(est["t"], named[:, plane], c=p[:, plane], s=6, cmap="viridis",
                          vmin=0, vmax=1, label="estimated")  # fmt: skip
        ax.set_yticks(range(len(STATES)), STATES)
        ax.set_ylabel(f"{name} state")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.colorbar(dots, ax=list(axes), label="probability")
    axes[0].set_title(f"Contact state by the {est['source']} (history of responses and poses)")
    axes[1].set_xlabel("t [s] (0: the first command)")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
