"""The contact state along an insertion from where the hole is: a particle filter over the
hole's unknown deviation, the part's μ, its radial gap and its contact stiffness, with the
contact model as the measurement (DESIGN §6; ``docs/boundary-mapping.md``).

One response cannot tell the states near their boundaries apart (a tilted peg that the law has
brought to Fx = 0 sits at eq. 20's shift, a D±1 by its features and a D0 by its response), but
the responses *along* an insertion, with the poses they were measured at, pin down where the
hole is. The hole's deviation ``x_dev = (dx, dy, ·, θx, θy)`` from where the robot believes it
is is constant, and the true features follow from it and the measured ones exactly
(:func:`~fbcc_ros.core.contact.features.true_rows`, the plant's own composition). So the
filter's hidden state is constant:

.. math::
    \\theta = (d_x, d_y, \\theta_x, \\theta_y, \\mu, g, \\ln k),\\qquad
    w_p \\propto w_p\\, p(y_t \\mid x_t(\\theta_p)),

with g the radial gap R − r off the nominal. Particles start uniform over the stated
:class:`~fbcc_ros.core.control.contact_uncertainty.Uncertainty` (deviations ±range, μ ×(1 ± f),
g ± 2·radius) and with k log-uniform over ``stiffness`` (default: the nominal k alone, the k the
user states, a band of the likelihood covering a part off it; :data:`UNKNOWN_STIFFNESS` for one
nobody knows). It is updated at every n-th sample with the mean response of the samples since
the last and their features (:mod:`~fbcc_ros.core.control.state_feed`): each particle predicts
at their mean, plus the window's gap between the mean response and the response at the mean,
taken for the cloud's weighted mean particle where it is an interference fit. Each
update, every particle's true features give its predicted response (the contact model of eq.
5-13 with its μ, gap and k; at :data:`WIDE_ANGLES` angles until the cloud has converged),
weighed by the measurement model of :mod:`~fbcc_ros.core.control.state_likelihood` (the
indicators u = F/Fz and σ in contact, whether a touch would show and the lateral force out of
it). For the first ``anneal`` updates the log-likelihood is scaled up from 0: on the hole's top
face a tilt and an offset read alike, and an early full weighting can settle the cloud on the
wrong one (without it, or over 50 updates, 1 of 4 interference insertions ended microns off;
over 200, none of 12). When the effective sample size falls under half, the particles are
resampled (systematically) with Liu and West's shrunk kernel (``a`` = 0.98), which keeps the
cloud's mean and spread; once it has converged, fewer. A moved particle stays in the prior.

A cloud can collapse where the responses no longer say which: a one-sided contact fixes the
offset less the gap, not each, and a peg that then rests in the clearance is pressing nowhere.
When every particle contradicts the measurement after the annealing (contact where there is
none, or the reverse), the weights cannot say where the cloud should be: it is spread out by
:data:`SPREAD_OUT` and weighed afresh, the contradiction's own sample skipped.

A cloud can also settle where the hole is not without any particle contradicting a sample: it
explains each one worse than the truth would, for as long as the insertion lasts. Its *surprise*
(:meth:`DeviationFilter.surprise`: the log of its weighted mean likelihood of a sample, plus
what the sensor's noise alone costs a particle at the truth under the same kernels) averages
zero when it is right and falls by nats a sample when it is lost. It is tracked from the first
update in the hole, the annealing's included (a cloud can settle wrong while it anneals). Its
mean over :data:`SURPRISE_MEMORY` updates below :data:`LOST`, the cloud is drawn again: the full
count from its weights, moved by :data:`REDRAW_SPREAD`, the gap from the prior, weighed afresh.

The state per plane is the particles' weighted vote of their states at their true features,
each with its own gap and its features known to within :data:`READOUT_SPREAD` (a cloud that has
weighed hundreds of samples of a peg resting still is surer of its features than the model
resolves them), calibrated (:mod:`~fbcc_ros.core.control.state_calibration`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.features import hole_frames, true_rows_at
from fbcc_ros.core.contact.model import ContactBatch, PegHole, as_rows
from fbcc_ros.core.contact.segmentation import STATES
from fbcc_ros.core.contact.spread_states import spread_states
from fbcc_ros.core.control.contact_uncertainty import Uncertainty
from fbcc_ros.core.control.state_calibration import calibrated
from fbcc_ros.core.control.state_feed import StateFeed, window_gap
from fbcc_ros.core.control.state_likelihood import (
    CONTACT_MISMATCH,
    ENTRY_DEPTH,
    log_likelihood,
    noise_misfit,
)
from fbcc_ros.core.errors import ConfigError

#: The least μ a particle may carry (the prior's μ range may reach 0).
MU_MIN = 0.01
#: Liu and West's shrinkage: the kernel keeps the cloud's mean and spread.
SHRINK = 0.98
#: A cloud is converged when its spread is under these in offset [m] and tilt [rad]: then
#: ``converged_particles`` carry it (measured on 8 interference insertions: 0.946 of the states
#: right with 500 after convergence, as with 4000 throughout, in 1.4 s of CPU instead of 4.8).
CONVERGED = (2e-6, 2e-4)
#: Until the cloud has converged (more than ``converged_particles`` carry it) the contact model
#: runs at this many angles instead of the nominal's (48 by default): the cloud is then
#: microns wide and the likelihood annealed. It costs 18-27 % less CPU and moves the share
#: named right within the filter's own randomness (docs/boundary-mapping.md).
WIDE_ANGLES = 24
#: How far a cloud that every particle of it contradicts is spread out (dx, dy, θx, θy, μ, g,
#: ln k): the size at which a cloud counts as converged, 0.03 in μ, 2 µm of gap, k ×e^±0.3.
SPREAD_OUT = (CONVERGED[0], CONVERGED[0], CONVERGED[1], CONVERGED[1], 0.03, 2e-6, 0.3)
#: Floors of the resampling kernel's covariance (dx, dy, θx, θy, μ, g, ln k): a collapsed cloud
#: still moves.
JITTER_FLOOR = (1e-7, 1e-7, 1e-5, 1e-5, 1e-3, 3e-8, 0.01)
#: A cloud is lost, and drawn again, when its surprise (:meth:`DeviationFilter.surprise`) averaged
#: over :data:`SURPRISE_MEMORY` updates is below this [nats a sample] (module doc).
LOST = -2.5
SURPRISE_MEMORY = 40
#: How far a redraw moves each particle (dx, dy, θx, θy, μ, ·, ln k): 10 µm, 5 mrad (lost clouds
#: were 10-15 mrad off in a tilt), 0.15 in μ, k ×e^±1.5. The gap is drawn from its prior: a
#: spread across its narrow range, clipped to it, would pile particles on its ends.
REDRAW_SPREAD = (1e-5, 1e-5, 5e-3, 5e-3, 0.15, 0.0, 1.5)
#: The spread (offset [m], tilt [rad]) within which a particle's true features are known when
#: its state is read (module doc): on the clearance states stated 0.9-0.99, right 67-92 % of
#: the time read at the point, 89-98 % with it (docs/boundary-mapping.md); the bands' ratio.
READOUT_SPREAD = (3e-7, 3e-5)
#: The ``stiffness`` range [Pa] for a part whose k is not known at all: what the package is built
#: for, soft plastic to steel (docs/reproduction.md).
UNKNOWN_STIFFNESS = (1e8, 1e11)


def stiffness_range(value: Sequence[float], name: str = "stiffness") -> tuple[float, float]:
    """A range of the part's k: two finite stiffnesses 0 < low <= high [Pa], else a
    ConfigError naming ``name``."""
    v = [float(x) for x in value]
    if not (len(v) == 2 and 0 < v[0] <= v[1] < math.inf):
        raise ConfigError(name, list(value), "two stiffnesses 0 < low <= high [Pa]")
    return v[0], v[1]


class DeviationFilter:
    """P(state) per plane along one insertion (module doc).

    Args:
        nominal: The nominal geometry.
        uncertainty: The deviations' ranges, μ's and the radii's spreads, the sensor's noise.
        particles: How many at the start (the prior is wide).
        converged_particles: How many once the cloud has converged (:data:`CONVERGED`).
        anneal: Updates over which the likelihood's weight rises from 0 to 1.
        stiffness: The contact stiffness's prior range [Pa], log-uniform (default: the nominal
            k alone, the one the user states).
        seed: The particles' seed.
    """

    def __init__(self, nominal: PegHole, uncertainty: Uncertainty | None = None, *,
                 particles: int = 4000, converged_particles: int = 500, anneal: int = 200,
                 stiffness: tuple[float, float] | None = None, seed: int = 0,
                 ) -> None:  # fmt: skip
        if particles < 100:
            raise ConfigError("particles", particles, "at least 100")
        if not 100 <= converged_particles <= particles:
            raise ConfigError("converged_particles", converged_particles,
                              f"from 100 to particles ({particles})")  # fmt: skip
        self.converged_particles = converged_particles
        if anneal < 0:
            raise ConfigError("anneal", anneal, "an update count >= 0")
        if stiffness is None:  # the stated k; MAGNITUDE_BAND covers the part being off it
            stiffness = (nominal.stiffness, nominal.stiffness)
        stiffness = stiffness_range(stiffness)
        self.nominal = nominal
        self.uncertainty = unc = uncertainty or Uncertainty()
        self.anneal = anneal
        self._rng = np.random.default_rng(seed)
        n = particles
        rng = self._rng
        self._theta = np.column_stack([
            rng.uniform(-unc.max_offset, unc.max_offset, (n, 2)),
            rng.uniform(-unc.max_tilt, unc.max_tilt, (n, 2)),
            nominal.friction * rng.uniform(1 - unc.friction, 1 + unc.friction, n),
            rng.uniform(-2 * unc.radius, 2 * unc.radius, n),
            rng.uniform(math.log(stiffness[0]), math.log(stiffness[1]), n),
        ])  # fmt: skip
        #: the prior's support, which a moved particle does not leave
        self._low = np.array([-unc.max_offset, -unc.max_offset, -unc.max_tilt, -unc.max_tilt,
                              max(MU_MIN, nominal.friction * (1 - unc.friction)),
                              -2 * unc.radius, math.log(stiffness[0])])  # fmt: skip
        self._high = np.array([unc.max_offset, unc.max_offset, unc.max_tilt, unc.max_tilt,
                               nominal.friction * (1 + unc.friction), 2 * unc.radius,
                               math.log(stiffness[1])])  # fmt: skip
        self._logw = np.zeros(n)
        self.updates = 0
        #: how often a contradicted cloud was spread out, and a lost one drawn again
        self.spread_outs = self.redraws = 0
        self._particles = n
        #: the surprise's running mean over SURPRISE_MEMORY updates (LOST and under: redrawn)
        self.surprise_mean = 0.0
        self._table = np.tile(ContactBatch.of([nominal]).table, (1, n))
        self._peg_top = nominal.acting_point == "peg_top"
        self._noise = np.asarray(unc.noise, dtype=float)

    @property
    def _theta(self) -> FloatArray:
        """The particles (P, 7): (dx, dy, θx, θy, μ, g, ln k)."""
        return self._cloud

    @_theta.setter
    def _theta(self, value: FloatArray) -> None:
        self._cloud = value
        #: each particle's hole frame (features.hole_frames) and its column of the contact
        #: model's table, found when first needed after the particles moved
        self._frames: FloatArray | None = None

    @property
    def weights(self) -> FloatArray:
        """The particles' normalised weights."""
        w = np.exp(self._logw - self._logw.max())
        return w / w.sum()  # type: ignore[no-any-return]

    def deviation(self) -> tuple[FloatArray, FloatArray]:
        """The weighted mean and standard deviation of (dx, dy, θx, θy, μ, g, ln k)."""
        w = self.weights
        mean = w @ self._theta
        return mean, np.sqrt(w @ (self._theta - mean) ** 2)

    def true_features(self, features: ArrayLike) -> FloatArray:
        """Each particle's true features (in the hole where it puts it) at the measured ones
        (5,), shape (P, 5): a view of a (5, P) array, each feature's column contiguous."""
        f, _ = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        if self._frames is None:  # the particles moved: their holes' frames, found once
            self._frames = np.empty((6, len(self._theta)))
            hole_frames(_deviations(self._theta), self.nominal.peg_radius, self._frames)
            self._table[0] = self.nominal.hole_radius + self._theta[:, 5]
            self._table[2] = self._theta[:, 4]
            self._table[3] = np.exp(self._theta[:, 6])
        out = np.empty((5, len(self._theta)))
        true_rows_at(np.ascontiguousarray(f[0]), self._frames, self.nominal.peg_radius,
                     self.nominal.peg_radius, out)  # fmt: skip
        return out.T

    def update(self, response: ArrayLike, features: ArrayLike) -> FloatArray:
        """Weigh the particles by one compensated response (5,) in {H} [N, N·m], the mean of the
        samples since the last update, measured at the robot's features: those samples' (n, 5)
        (:class:`~fbcc_ros.core.control.state_feed.FeedSample`'s window) or one (5,). Returns
        P(state) per plane, shape (2, 9), read at the last row's features."""
        w, _ = as_rows(response, "response", "(Fx, Fy, Fz, Mx, My) in N, N·m")
        window, _ = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        depth = max(float(window.mean(axis=0)[2]), 0.0)
        prior = self.weights
        ll = self._log_likelihoods(w[0], window, prior)
        self.updates += 1
        scale = min(1.0, self.updates / self.anneal) if self.anneal else 1.0
        annealed = self.updates > self.anneal
        if depth > ENTRY_DEPTH:  # on the top face the model does not describe the contact
            s = self.surprise(w[0], depth, ll, prior, len(window))
            self.surprise_mean += (s - self.surprise_mean) / SURPRISE_MEMORY
        lost = self.surprise_mean < LOST
        if ll.max() <= CONTACT_MISMATCH and annealed:
            # every particle says contact where there is none (or none where there is): the
            # cloud is wrong, and its weights cannot say where; it is spread out again
            self._spread_out()
        else:
            self._logw += scale * ll
        self._logw -= self._logw.max()
        weights = self.weights
        # the state where the peg is at the last sample, of the particles as they are now
        probabilities = self.states(self.true_features(window[-1]), weights)
        if lost:  # explains the samples far worse than the truth would, for many of them
            self._redraw(weights)
        elif 1.0 / np.sum(weights**2) < len(weights) / 2:
            self._resample(weights)
        return probabilities

    def log_likelihoods(self, response: ArrayLike, features: ArrayLike,
                        weights: FloatArray | None = None) -> FloatArray:  # fmt: skip
        """Each particle's log-likelihood (P,) of one sample, :meth:`update`'s arguments, not
        weighed in; ``weights`` the normalised ones when the caller has them."""
        w, _ = as_rows(response, "response", "(Fx, Fy, Fz, Mx, My) in N, N·m")
        window, _ = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        return self._log_likelihoods(w[0], window, weights)

    def _log_likelihoods(self, w: FloatArray, window: FloatArray,
                         weights: FloatArray | None) -> FloatArray:  # fmt: skip
        """:meth:`log_likelihoods` of a checked response (5,) and window (n, 5)."""
        mean = window.mean(axis=0)
        touching = np.ascontiguousarray(self.true_features(mean))  # the contact model's rows
        np.maximum(touching[:, 2], 0.0, out=touching[:, 2])
        angles = self.nominal.n_angles
        if len(self._theta) > self.converged_particles:  # not converged: a coarser model
            angles = min(angles, WIDE_ANGLES)
        predicted = ContactBatch(self._table, self._peg_top, angles).response(touching)
        if len(window) > 1:
            weights = self.weights if weights is None else weights
            predicted += self._window_gap(window, angles, predicted[:, 2], weights)
        return log_likelihood(w, max(float(mean[2]), 0.0), predicted, touching[:, 2],
                              self.nominal, self._noise)  # fmt: skip

    def _window_gap(self, window: FloatArray, angles: int, fz: FloatArray,
                    weights: FloatArray) -> FloatArray:  # fmt: skip
        """What to add to each particle's prediction at the window's mean features (P, 5), with
        its Fz ``fz`` (P,) and the particles' normalised ``weights``, for the mean response of
        the window (n, 5) it is compared with: the gap of the cloud's weighted mean particle
        (:func:`window_gap`), in proportion to each particle's Fz over that particle's (k
        scales a response, and cancels in the indicators). Only where that particle's part is
        an interference fit and it touches at every row and at the mean (``state_feed``'s
        module doc); else nothing."""
        mean = weights @ self._theta
        pair = self._table[:, :1].copy()
        pair[[0, 2, 3], 0] = self.nominal.hole_radius + mean[5], mean[4], math.exp(mean[6])
        if pair[0, 0] >= pair[1, 0]:  # a clearance: the peg touches on one side, or not
            return np.zeros((len(fz), 5))
        gap, h = window_gap(window, _deviations(mean[None])[0], pair, self._peg_top, angles,
                            self.nominal.peg_radius)  # fmt: skip
        if not (h[:, 2] > 0.0).all():
            return np.zeros((len(fz), 5))
        return (fz / h[-1, 2])[:, None] * gap

    def surprise(self, w: FloatArray, depth: float, ll: FloatArray,
                 weights: FloatArray | None = None, samples: int = 1) -> float:  # fmt: skip
        """How much better (> 0) or worse (< 0) the cloud explains one sample (5,), the mean of
        ``samples``, whose log-likelihood per particle is ``ll``, than a particle at the truth
        would on average [nats]: the log of the weighted mean likelihood plus what the noise
        alone costs (:func:`~fbcc_ros.core.control.state_likelihood.noise_misfit`). A lost
        cloud pays nats a sample more than a right one."""
        top = float(ll.max())
        weights = self.weights if weights is None else weights
        mean = float(np.log(weights @ np.exp(ll - top))) + top
        return mean + noise_misfit(w, depth, self.nominal, self._noise, samples)

    def states(self, x: FloatArray, weights: FloatArray | None = None,
               spread: tuple[float, float] = READOUT_SPREAD) -> FloatArray:  # fmt: skip
        """The weighted vote of the particles' states at their true features x (P, 5), each
        with its own gap, each read with the features known to within ``spread`` (offset [m],
        tilt [rad]), calibrated (:mod:`~fbcc_ros.core.control.state_calibration`); ``weights``
        the normalised ones when the caller has them."""
        weights = self.weights if weights is None else weights
        hole = self.nominal.hole_radius + self._theta[:, 5]
        return calibrated(np.array([spread_states(d, t, x[:, 2], hole, self.nominal.peg_radius,
                                                  *spread).vote(weights)
                                    for d, t in ((x[:, 0], x[:, 4]), (x[:, 1], x[:, 3]))]),
                          self.nominal.fit)  # fmt: skip

    def _scatter(self, spread: Sequence[float]) -> None:
        """Every particle moved by a normal draw of standard deviations ``spread`` (7,), within
        the prior, the weights made equal."""
        self._theta += self._rng.normal(0.0, spread, self._theta.shape)
        self._moved()
        self._logw = np.zeros(len(self._theta))

    def _spread_out(self) -> None:
        """A contradicted cloud spread out by SPREAD_OUT (module doc)."""
        self._scatter(SPREAD_OUT)
        self.spread_outs += 1

    def _redraw(self, weights: FloatArray) -> None:
        """A lost cloud drawn again: the full particle count from its weights, moved by
        REDRAW_SPREAD, the gap from its prior (module doc)."""
        n = self._particles
        self._theta = self._theta[self._systematic(weights, n)]
        self._theta[:, 5] = self._rng.uniform(self._low[5], self._high[5], n)
        self._table = np.tile(self._table[:, :1], (1, n))
        self._scatter(REDRAW_SPREAD)
        self.surprise_mean = 0.0
        self.redraws += 1

    def _resample(self, weights: FloatArray) -> None:
        n = len(weights)
        _, spread = self.deviation()
        if (spread[:2] < CONVERGED[0]).all() and (spread[2:4] < CONVERGED[1]).all():
            n = min(n, self.converged_particles)  # a tight cloud needs fewer to stay tight
            self._table = self._table[:, :n].copy()
        index = self._systematic(weights, n)
        mean = weights @ self._theta
        centred = self._theta - mean  # the weighted covariance: defined for any weights
        cov = (weights * centred.T) @ centred + np.diag(np.square(JITTER_FLOOR))
        # N(0, (1 - a^2) cov) by its Cholesky factor (the floors keep cov positive definite)
        root = np.linalg.cholesky((1 - SHRINK**2) * cov)
        kernel = self._rng.standard_normal((n, len(mean))) @ root.T
        self._theta = SHRINK * self._theta[index] + (1 - SHRINK) * mean + kernel
        self._moved()
        self._logw = np.zeros(n)

    def _systematic(self, weights: FloatArray, n: int) -> NDArray[np.intp]:
        """n particles drawn by weight systematically (n even steps, one random offset)."""
        points = (self._rng.random() + np.arange(n)) / n
        return np.minimum(np.searchsorted(np.cumsum(weights), points), len(weights) - 1)

    def _moved(self) -> None:
        """After the particles moved: each stays within the prior's support (a kernel or a
        spread could take it out: a gap the tolerances do not allow, a negative μ)."""
        np.clip(self._theta, self._low, self._high, out=self._theta)
        self._frames = None


def _deviations(theta: FloatArray) -> FloatArray:
    """The hole deviations (P, 5) ``(dx, dy, 0, θx, θy)`` of particles ``theta`` (P, 7)."""
    dev = np.zeros((len(theta), 5))
    dev[:, [0, 1, 3, 4]] = theta[:, :4]
    return dev


def along(features: FloatArray, responses: FloatArray, nominal: PegHole, every: int = 1,
          **options: Any) -> tuple[np.ndarray, FloatArray]:  # fmt: skip
    """The filter along one recorded insertion: measured features and compensated responses,
    both (T, 5); updated at the rows :class:`StateFeed` takes (every ``every``-th from the first
    in contact or in the hole) with what it hands over there (the mean since the last update).
    Returns the rows it updated at and P(state) there, shape (K, 2, 9). ``options`` go to
    :class:`DeviationFilter`."""
    rows, handed = StateFeed(every).samples(features, responses)
    f = DeviationFilter(nominal, **options)
    return rows, np.array([f.update(*sample) for sample in handed]).reshape(-1, 2, len(STATES))
