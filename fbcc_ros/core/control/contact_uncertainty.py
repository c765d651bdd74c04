"""What is not known about a part and its contact (:class:`Uncertainty`), and features drawn
inside a contact state under it (:func:`draw_in_state`): the draws from which
:mod:`fbcc_ros.core.control.contact_state` builds its measurement model, and on which
:mod:`fbcc_ros.core.sim.state_study` scores it."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.contact.segmentation import (
    OFFSET_TOL,
    SIGNS,
    STATES,
    TILT_TOL,
    feature_state,
)
from fbcc_ros.core.control.robust_params import DEFAULT_SENSOR_NOISE
from fbcc_ros.core.errors import ConfigError, InputError

#: How :class:`Uncertainty` draws an offset's or a tilt's magnitude off its band.
MAGNITUDES = ("log", "uniform")


@dataclasses.dataclass(frozen=True)
class Uncertainty:
    """What is not known about a part and its contact, for drawing the measurement model.

    Attributes:
        radius: Each radius (hole and peg) uniform within ± this of the nominal [m].
        friction: μ times U(1 - friction, 1 + friction).
        stiffness_octaves: k times 2^U(-o, o).
        max_offset: The offsets' range, ± [m].
        max_tilt: The tilts' range, ± [rad].
        depth_range: Depths drawn [m]; also the bins' range.
        noise: The sensor's standard deviations of (Fx, Fy, Fz, Mx, My) [N, N·m].
        magnitudes: How an offset or tilt off its band is drawn: ``log`` (log-uniform from the
            band to the range: every decade alike, as an insertion goes through them all) or
            ``uniform`` (over the range: nine tenths above a tenth of it).
    """

    radius: float = 3e-6
    friction: float = 0.5
    stiffness_octaves: float = 1.0
    max_offset: float = 1e-4
    max_tilt: float = math.radians(2.0)
    depth_range: tuple[float, float] = (1e-3, 10e-3)
    noise: tuple[float, float, float, float, float] = DEFAULT_SENSOR_NOISE
    magnitudes: str = "log"

    def __post_init__(self) -> None:
        if self.magnitudes not in MAGNITUDES:
            raise ConfigError("uncertainty.magnitudes", self.magnitudes,
                              f"one of {list(MAGNITUDES)}")  # fmt: skip
        for name in ("radius", "friction", "stiffness_octaves"):
            if not math.isfinite(getattr(self, name)) or getattr(self, name) < 0:
                raise ConfigError(f"uncertainty.{name}", getattr(self, name),
                                  "a finite value >= 0")  # fmt: skip
        if not 0 <= self.friction < 1:
            raise ConfigError("uncertainty.friction", self.friction, "in [0, 1): μ stays > 0")
        for name in ("max_offset", "max_tilt"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"uncertainty.{name}", getattr(self, name), "> 0")
        lo, hi = self.depth_range
        if not 0 < lo < hi:
            raise ConfigError("uncertainty.depth_range", list(self.depth_range),
                              "two depths 0 < low < high [m]")  # fmt: skip
        if len(self.noise) != 5 or any(not (n >= 0 and math.isfinite(n)) for n in self.noise):
            raise ConfigError("uncertainty.noise", list(self.noise),
                              "five finite standard deviations >= 0")  # fmt: skip

    def part(self, nominal: PegHole, rng: np.random.Generator) -> PegHole:
        """One part drawn around the nominal one."""
        r = self.radius
        return nominal.replace(
            hole_radius=nominal.hole_radius + rng.uniform(-r, r),
            peg_radius=nominal.peg_radius + rng.uniform(-r, r),
            friction=nominal.friction * rng.uniform(1 - self.friction, 1 + self.friction),
            stiffness=nominal.stiffness * 2.0 ** rng.uniform(-self.stiffness_octaves,
                                                               self.stiffness_octaves),
        )  # fmt: skip

    def noisy(self, response: FloatArray, rng: np.random.Generator) -> FloatArray:
        """Responses with the sensor's noise added where the peg is in contact (a no-contact
        response stays exactly zero: the compensation's tare reads the sensor then)."""
        touching = (np.abs(response) > 0).any(axis=1, keepdims=True)
        return response + touching * rng.normal(0.0, 1.0, response.shape) * np.array(self.noise)


def draw_in_state(state: str, n: int, part: PegHole, unc: Uncertainty,
                  rng: np.random.Generator, depth: tuple[float, float] | None = None,
                  ) -> FloatArray:  # fmt: skip
    """``n`` features whose XOZ state on ``part`` is ``state`` (fewer if the state is
    (nearly) empty there, as P0 of an interference fit outside its point): the XOZ offset and
    tilt on the state's side of each band (:func:`_signed`), the YOZ plane in a random state
    alike, the depth uniform in ``depth`` (default the uncertainty's range)."""
    if state not in STATES:
        raise InputError("state", state, f"one of {list(STATES)}")
    d_sign, t_sign = SIGNS[STATES.index(state)]
    lo, hi = depth or unc.depth_range
    out: list[FloatArray] = []
    got = 0
    for _ in range(20):  # rejection: the side of the band, then the truth on the drawn part
        m = 4 * n
        offset = (OFFSET_TOL, unc.max_offset, m, unc.magnitudes)
        tilt = (TILT_TOL, unc.max_tilt, m, unc.magnitudes)
        f = np.column_stack([
            _signed(rng, d_sign, *offset),
            _signed(rng, rng.integers(-1, 2, m), *offset),  # the other plane in any state
            rng.uniform(lo, hi, m),
            _signed(rng, rng.integers(-1, 2, m), *tilt),
            _signed(rng, t_sign, *tilt),
        ])  # fmt: skip
        if state == "P0" and part.fit == "clearance":  # the rhombus of eq. 15, not the bands
            c = part.hole_radius - part.peg_radius
            f[:, 0] = rng.uniform(-c, c, m)
            f[:, 4] = rng.uniform(-1, 1, m) * 2 * c / f[:, 2]
        keep = np.asarray(feature_state(f, part)[0]) == state
        out.append(f[keep])
        got += int(keep.sum())
        if got >= n:
            break
    return np.concatenate(out)[:n]


def _signed(rng: np.random.Generator, sign: int | np.ndarray, tol: float, top: float,
            m: int, magnitudes: str) -> FloatArray:  # fmt: skip
    """Within the band ``|x| <= tol`` where the sign is 0, else of that sign with a magnitude
    from ``tol`` to ``top``, log-uniform or uniform (:class:`Uncertainty`)."""
    band = rng.uniform(-tol, tol, m)
    if magnitudes == "log":
        size = tol * (top / tol) ** rng.uniform(0.0, 1.0, m)
    else:
        size = rng.uniform(tol, top, m)
    return np.where(np.asarray(sign) == 0, band, np.sign(sign) * size)
