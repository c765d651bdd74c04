"""Which contact state a response comes from, with its probability: a Bayes classifier whose
measurement model is the contact model itself (eq. 5-13) under the part's uncertainty.

Boundary mapping (:func:`~fbcc_ros.core.contact.segmentation.response_state`) names a state by
the side of two lines a response falls on, with bands for the lines themselves. Under real
uncertainty the lines move (the friction arm μR of eq. 24, the r·sin θ of eq. 5) and the
on-boundary states (P±1, D0, D^0, P0), each a band of a micrometre or 0.1 mrad, are named
right only by chance (``docs/boundary-mapping.md``). This estimator instead asks, per plane,
how likely the observed response is under each state:

.. math::
    P(s \\mid y, l) = \\frac{\\pi_s\\, p(y \\mid s, l)}{\\sum_{s'} \\pi_{s'}\\, p(y \\mid s', l)},

with y the plane's indicators in the normalised plane of Fig. 6 (``u = F/Fz`` and σ, the
signed distance to the image of θ = 0, as
:func:`~fbcc_ros.core.contact.segmentation.normalised_coordinates` gives them), l the measured
depth and π a prior over the nine states (uniform unless given).

``p(y | s, l)`` is learnt once, at construction, from the contact model. For every state,
depth bin and friction bin:

* features drawn inside the state, on parts drawn around the nominal one
  (:mod:`~fbcc_ros.core.control.contact_uncertainty`: radii, μ and k are the nuisance
  parameters, marginalised by drawing them); the truth is
  :func:`~fbcc_ros.core.contact.segmentation.feature_state` on the drawn part;
* their responses, with the sensor's noise;
* a Gaussian kernel density in ``(asinh(u/U_SCALE), asinh(σ/SIGMA_SCALE))`` (which spreads
  the narrow on-boundary clouds and compresses the far tails), Scott's bandwidth, tabulated on
  a grid and read bilinearly.

"No contact" (Fz at most ``fz_min``) is its own observation, with each state's share of it
in the draws.

Both planes are classified with the one table: in (u, σ) and (offset sign, tilt sign) a 90°
rotation about z carries XOZ onto YOZ unchanged (``docs/boundary-mapping.md``), so the table is
drawn in XOZ, the YOZ features random.

Along an insertion the states are near their boundaries, where one response does not tell
them apart: :mod:`fbcc_ros.core.control.deviation_filter` estimates them from the history.

What it achieves, measured (``fbcc-mapping-study --estimator``, ``docs/boundary-mapping.md``):
better than the sector rule and boundary mapping on drawn responses; along simulated
insertions, about as well as boundary mapping.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import ContactBatch, PegHole, as_rows
from fbcc_ros.core.contact.segmentation import (
    FZ_MIN,
    STATES,
    normalised_coordinates,
)
from fbcc_ros.core.control.contact_uncertainty import Uncertainty, draw_in_state
from fbcc_ros.core.errors import ConfigError, InputError

#: Scales of the kernel's coordinates asinh(u / U_SCALE), asinh(σ / SIGMA_SCALE): about the
#: spread of the on-boundary clouds (dx = 0 images at |u| ~ 0.1 through eq. 20's shift; θ = 0
#: leaks to |σ| ~ 0.003 through the other plane), so both are resolved and the far tails
#: (|u| up to 1/μ) do not dominate a bandwidth.
U_SCALE = 0.05
SIGMA_SCALE = 0.002
#: A state's share of "no contact" observations is at least this (no probability is 0).
NO_CONTACT_FLOOR = 1e-3
#: The table's grid in the kernel's coordinates: nodes from LOW, CELL apart. |u| to 1/μ
#: (asinh(6.7 / U_SCALE) = 5.6) and |σ| to about 3 (asinh(3 / SIGMA_SCALE) = 8.0) are inside.
LOW = (-6.0, -8.5)
CELL = 0.25
GRID = (49, 69)
#: A density floor under every state, per unit of the grid's area, so that no response has
#: likelihood 0 under a state (a response off every table: a fault, a model error).
DENSITY_FLOOR = 1e-6

def indicators(response: FloatArray, depth: FloatArray, nominal: PegHole,
               fz_min: float = FZ_MIN) -> tuple[FloatArray, np.ndarray]:  # fmt: skip
    """Per plane the kernel's coordinates, shape (N, 2, 2): [plane (XOZ, YOZ)][asinh u,
    asinh σ]; and whether each response is in contact (Fz over ``fz_min``), shape (N,)."""
    u_x, s_x, u_y, s_y = normalised_coordinates(response, depth, nominal)
    contact = response[:, 2] > fz_min
    z = np.zeros((len(response), 2, 2))
    z[:, 0, 0], z[:, 0, 1] = np.arcsinh(u_x / U_SCALE), np.arcsinh(s_x / SIGMA_SCALE)
    z[:, 1, 0], z[:, 1, 1] = np.arcsinh(u_y / U_SCALE), np.arcsinh(s_y / SIGMA_SCALE)
    z[~contact] = 0.0
    return z, contact


class ContactStateEstimator:
    """The measurement model p(y | state, l, μ) per plane (module doc), tabulated for one
    nominal part, and the single-sample posterior.

    Args:
        nominal: The nominal geometry (what the controller is told).
        uncertainty: What is not known (:class:`Uncertainty`).
        samples: Draws per state, depth bin and friction bin.
        bins: Depth bins over ``uncertainty.depth_range``.
        friction_bins: Bins of μ over its range (marginalised: a later estimate of μ can pick
            one).
        parts: Parts drawn per state and bin (the draws spread over them).
        seed: The draws' seed (the table is the same for the same arguments).
        prior: π over :data:`STATES` (default uniform).
    """

    def __init__(self, nominal: PegHole, uncertainty: Uncertainty | None = None, *,
                 samples: int = 300, bins: int = 10, friction_bins: int = 5, parts: int = 10,
                 seed: int = 0, prior: ArrayLike | None = None) -> None:  # fmt: skip
        if samples < 20 or bins < 1 or friction_bins < 1 or parts < 1:
            raise ConfigError("samples, bins, friction_bins, parts",
                              [samples, bins, friction_bins, parts],
                              "samples >= 20 and the others >= 1")  # fmt: skip
        self.nominal = nominal
        self.uncertainty = unc = uncertainty or Uncertainty()
        n_s = len(STATES)
        pi = np.full(n_s, 1.0 / n_s) if prior is None else np.asarray(prior, dtype=float)
        if pi.shape != (n_s,) or not np.isfinite(pi).all() or (pi < 0).any() or not pi.sum() > 0:
            raise ConfigError("prior", np.asarray(prior).tolist(),
                              f"{n_s} probabilities >= 0, not all zero")  # fmt: skip
        self.prior = pi / pi.sum()
        self.edges = np.linspace(*unc.depth_range, bins + 1)
        f = unc.friction
        self.friction_edges = nominal.friction * np.linspace(1 - f, 1 + f, friction_bins + 1)
        rng = np.random.default_rng(seed)
        self.density = np.zeros((bins, friction_bins, n_s, GRID[0], GRID[1]))
        self.no_contact = np.full((bins, friction_bins, n_s), NO_CONTACT_FLOOR)
        for b in range(bins):
            for m in range(friction_bins):
                for s, state in enumerate(STATES):
                    self._tabulate(b, m, s, state, samples, parts, rng)

    def _tabulate(self, b: int, m: int, s: int, state: str, n: int, parts: int,
                  rng: np.random.Generator) -> None:  # fmt: skip
        """One cell of the table: draws in ``state`` at depth bin b, friction bin m."""
        depth = (self.edges[b], self.edges[b + 1])
        mu = (self.friction_edges[m], self.friction_edges[m + 1])
        per = max(1, n // parts)
        feats, pegholes = [], []
        for _ in range(parts):
            part = self.uncertainty.part(self.nominal, rng).replace(friction=rng.uniform(*mu))
            f = draw_in_state(state, per, part, self.uncertainty, rng, depth)
            feats.append(f)
            pegholes += [part] * len(f)
        f = np.concatenate(feats)
        if len(f) == 0:  # a state the parts do not have (P0 of an interference fit, nearly)
            return
        w = self.uncertainty.noisy(ContactBatch.of(pegholes).response(f), rng)
        z, contact = indicators(w, f[:, 2], self.nominal)
        self.no_contact[b, m, s] = max(NO_CONTACT_FLOOR, 1.0 - contact.mean())
        pts = np.ascontiguousarray(z[contact, 0])
        if len(pts) == 0:
            return
        # Scott's rule in two dimensions: n^(-1/6) times the spread (not under a grid cell)
        h = np.maximum(pts.std(axis=0), CELL) * len(pts) ** (-1.0 / 6.0)
        h = np.maximum(h, CELL)
        _kde_on_grid(pts, h, 1.0 - self.no_contact[b, m, s], self.density[b, m, s])

    def likelihood(self, response: ArrayLike, depth: ArrayLike) -> FloatArray:
        """p(y | state, l, μ bin) per plane, shape (N, 2, friction bins, 9)."""
        w, _ = as_rows(response, "response", "(Fx, Fy, Fz, Mx, My) in N, N·m")
        l = np.broadcast_to(np.asarray(depth, dtype=float), (len(w),))
        if not np.isfinite(l).all():
            raise InputError("depth", l.tolist(), "finite depths [m]")
        z, contact = indicators(w, l, self.nominal)
        b = np.clip(np.searchsorted(self.edges, l, side="right") - 1, 0, len(self.edges) - 2)
        out = np.empty((len(w), 2, self.density.shape[1], len(STATES)))
        _lookup(z, contact, b, self.density, self.no_contact, out)
        return out

    def probabilities(self, response: ArrayLike, depth: ArrayLike) -> FloatArray:
        """P(state | one response, depth) per plane, μ marginalised over its bins: shape
        (N, 2, 9), [row][plane XOZ, YOZ][state of :data:`STATES`]."""
        joint = self.likelihood(response, depth).mean(axis=2) * self.prior
        total = joint.sum(axis=2, keepdims=True)
        return np.where(total > 0, joint / np.where(total > 0, total, 1.0), self.prior)


def most_probable(p: FloatArray) -> tuple[np.ndarray, FloatArray]:
    """The most probable state and its probability, from probabilities (..., 9)."""
    best = p.argmax(axis=-1)
    names = np.asarray(STATES, dtype=object)[best]
    return names, np.take_along_axis(p, best[..., None], -1)[..., 0]


@numba.njit(cache=True)
def _kde_on_grid(pts: FloatArray, h: FloatArray, scale: float, out: FloatArray) -> None:
    """``scale`` times the Gaussian kernel density of ``pts`` at the grid's nodes."""
    n = pts.shape[0]
    norm = scale / (n * 2 * math.pi * h[0] * h[1])
    for i in range(GRID[0]):
        a0 = LOW[0] + i * CELL
        for j in range(GRID[1]):
            a1 = LOW[1] + j * CELL
            acc = 0.0
            for k in range(n):
                x = (a0 - pts[k, 0]) / h[0]
                y = (a1 - pts[k, 1]) / h[1]
                e = 0.5 * (x * x + y * y)
                if e < 30.0:
                    acc += math.exp(-e)
            out[i, j] = norm * acc + DENSITY_FLOOR * scale


@numba.njit(cache=True)
def _lookup(z: FloatArray, contact: np.ndarray, b: np.ndarray, density: FloatArray,
            no_contact: FloatArray, out: FloatArray) -> None:  # fmt: skip
    """The tabulated likelihood at each row's indicators (bilinear between the grid's nodes;
    beyond the grid, its edge)."""
    for r in range(z.shape[0]):
        k = b[r]
        for plane in range(2):
            gi = min(max((z[r, plane, 0] - LOW[0]) / CELL, 0.0), GRID[0] - 1.000001)
            gj = min(max((z[r, plane, 1] - LOW[1]) / CELL, 0.0), GRID[1] - 1.000001)
            i, j = int(gi), int(gj)
            fi, fj = gi - i, gj - j
            for m in range(density.shape[1]):
                for s in range(density.shape[2]):
                    if not contact[r]:
                        out[r, plane, m, s] = no_contact[k, m, s]
                        continue
                    d = density[k, m, s]
                    out[r, plane, m, s] = ((1 - fi) * ((1 - fj) * d[i, j] + fj * d[i, j + 1])
                                           + fi * ((1 - fj) * d[i + 1, j] + fj * d[i + 1, j + 1]))
