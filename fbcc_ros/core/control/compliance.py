"""The paper's compliance: Table I's gains (:class:`ComplianceParams`, eq. 30) and the
second-order compliance filter of eq. (27) (:class:`ComplianceFilter`), one per feature, that the
FBCC and admittance laws (:mod:`fbcc_ros.core.control.laws`) share.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import scipy.linalg

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.errors import ConfigError, InputError, require_number
from fbcc_ros.core.filters import second_order_row
from fbcc_ros.core.paper import TABLE_I

#: The fastest mode of every filter must satisfy |s| dt <= this (at least ~6 samples per
#: time constant or natural period / 2 pi), so that the sampled loop follows the continuous law.
MAX_POLE_DT = 1.0


@dataclasses.dataclass(frozen=True)
class ComplianceParams:
    """Gains of eq. (30) and the limits of Algorithm 1. Defaults: Table I, label 3.

    The suffixes follow the paper: ``p`` the offsets (dx, dy), ``o`` the tilts (theta_x,
    theta_y), ``l`` the depth. Units are those that make ``M x'' + D x' + K x = A F`` hold with
    A F in N: for FBCC x_d is a rate, so K_dp is in N·s/m, K_do in N·s/rad; for admittance x_d is
    a displacement and K_dp is in N/m, K_do in N/rad.

    Attributes:
        M_dp, D_dp, K_dp: offsets. M_do, D_do, K_do: tilts. M_dl, D_dl, K_dl: depth.
        x_d_limit_p: Dead band on |x_d| of the offsets [m/s] (FBCC only); 0 disables it.
        x_d_limit_o: Dead band on |x_d| of the tilts [rad/s] (FBCC only); 0 disables it.
        F_ext_limit: Force limit [N] on |(Fx, Fy, Fz)|: above it the insertion stops and the
            command is held (Algorithm 1's loop condition). The paper gives no value; 300 N is
            about twice the largest peak of FBCC over 2000 random trials of the paper's pairs
            (docs/reproduction.md) and within what an iiwa 14 can push.
    """

    M_dp: float = 1e4
    K_dp: float = 1e6
    D_dp: float = 1e5
    M_do: float = 1e1
    K_do: float = 1e3
    D_do: float = 1e2
    M_dl: float = 1e10
    K_dl: float = 1e12
    D_dl: float = 1e11
    x_d_limit_p: float = 0.0
    x_d_limit_o: float = 0.0
    F_ext_limit: float = 300.0

    NAMES: ClassVar[tuple[str, ...]] = (
        "M_dp", "K_dp", "D_dp", "M_do", "K_do", "D_do", "M_dl", "K_dl", "D_dl",
        "x_d_limit_p", "x_d_limit_o", "F_ext_limit",
    )  # fmt: skip

    def __post_init__(self) -> None:
        for name in self.NAMES:
            require_number(name, getattr(self, name))
        for name in ("M_dp", "K_dp", "M_do", "K_do", "M_dl", "K_dl", "F_ext_limit"):
            if getattr(self, name) <= 0:
                raise ConfigError(name, getattr(self, name), "> 0")
        for name in ("D_dp", "D_do", "D_dl", "x_d_limit_p", "x_d_limit_o"):
            if getattr(self, name) < 0:
                raise ConfigError(name, getattr(self, name), ">= 0")

    @classmethod
    def table_i(cls, label: int, **changes: float) -> ComplianceParams:
        """Table I, label 1-5, with D_d = sqrt(M_d K_d) as the table says; ``changes`` override."""
        if label not in TABLE_I:
            raise ConfigError("label", label, f"a Table I label, one of {sorted(TABLE_I)}")
        m_p, k_p, m_o, k_o, m_l, k_l = TABLE_I[label]
        gains = {
            "M_dp": m_p, "K_dp": k_p, "D_dp": math.sqrt(m_p * k_p),
            "M_do": m_o, "K_do": k_o, "D_do": math.sqrt(m_o * k_o),
            "M_dl": m_l, "K_dl": k_l, "D_dl": math.sqrt(m_l * k_l),
        }  # fmt: skip
        return cls(**{**gains, **changes})

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any], field: str = "params") -> ComplianceParams:
        """From a YAML mapping: ``label`` (default 3) picks the Table I row, other keys override.

        A D that is not given follows its M and K (sqrt(M K)) when either was overridden.
        """
        unknown = sorted(set(values) - {*cls.NAMES, "label"})
        if unknown:
            raise ConfigError(f"{field}.{unknown[0]}", values[unknown[0]],
                              f"one of label, {', '.join(cls.NAMES)}")  # fmt: skip
        label = values.get("label", 3)
        if isinstance(label, bool) or label not in TABLE_I:
            raise ConfigError(
                f"{field}.label", label, f"a Table I label, one of {sorted(TABLE_I)}"
            )
        base = cls.table_i(label)
        changes = {k: v for k, v in values.items() if k != "label"}
        for suffix in ("p", "o", "l"):
            d, m, k = f"D_d{suffix}", f"M_d{suffix}", f"K_d{suffix}"
            if d not in changes and (m in changes or k in changes):
                m_v, k_v = changes.get(m, getattr(base, m)), changes.get(k, getattr(base, k))
                numbers = all(isinstance(v, (int, float)) for v in (m_v, k_v))
                if numbers and m_v * k_v > 0:  # otherwise __post_init__ names the bad value
                    changes[d] = math.sqrt(m_v * k_v)
        try:
            return cls.table_i(label, **changes)
        except ConfigError as exc:
            raise ConfigError(f"{field}.{exc.field}", exc.value, exc.allowed) from None

    def diagonal(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """M_d, D_d, K_d of eq. (30) as vectors in feature order (dx, dy, l, theta_x, theta_y)."""
        m = np.array([self.M_dp, self.M_dp, self.M_dl, self.M_do, self.M_do])
        d = np.array([self.D_dp, self.D_dp, self.D_dl, self.D_do, self.D_do])
        k = np.array([self.K_dp, self.K_dp, self.K_dl, self.K_do, self.K_do])
        return m, d, k


class ComplianceFilter:
    """``M_d x_d'' + D_d x_d' + K_d x_d = u`` (eq. 27 and 30), one filter per feature.

    Discretised exactly for a zero-order hold on u (the matrix exponential of each 2×2 system),
    so any positive M, K and D >= 0 stay stable at any period. What we do check is that the
    period resolves the filter: the fastest mode s of ``M s² + D s + K`` must satisfy
    ``|s| dt <= MAX_POLE_DT``; otherwise the sampled loop no longer behaves like the law.
    """

    def __init__(self, params: ComplianceParams) -> None:
        self.params = params
        self._m, self._d, self._k = params.diagonal()
        self._coeffs: dict[float, FloatArray] = {}
        self._x = np.zeros((1, 5))
        self._v = np.zeros((1, 5))

    def reset(self, n: int) -> None:
        """Zero state (Algorithm 1: x_d(0) = x_d(-1) = 0) for n trials."""
        self._x = np.zeros((n, 5))
        self._v = np.zeros((n, 5))

    @property
    def output(self) -> FloatArray:
        """x_d, shape (N, 5)."""
        return self._x

    def step(self, u: FloatArray, dt: float) -> FloatArray:
        """Advance by dt with the input u (N, 5) held; returns x_d (N, 5)."""
        c = self.coefficients(dt)
        x, v = self._x.copy(), self._v.copy()
        u = np.ascontiguousarray(u, dtype=float)
        for i in range(len(x)):
            second_order_row(c, x[i], v[i], u[i])
        self._x, self._v = x, v
        return x

    def coefficients(self, dt: float) -> FloatArray:
        """:meth:`discretise`'s, from the cache after the first call."""
        c = self._coeffs.get(dt)
        return self.discretise(dt) if c is None else c

    def state(self) -> tuple[FloatArray, FloatArray]:
        """x_d and its rate, (N, 5) each: the arrays the law's compiled step advances."""
        return self._x, self._v

    def max_period(self) -> float:
        """The longest period dt [s] that still resolves every filter (see the class doc)."""
        poles = [np.roots([m, d, k]) for m, d, k in zip(self._m, self._d, self._k, strict=True)]
        return MAX_POLE_DT / max(float(np.max(np.abs(p))) for p in poles)

    def discretise(self, dt: float) -> FloatArray:
        """The coefficients at period dt, (6, 5): rows Phi00, Phi01, Phi10, Phi11, Gamma0,
        Gamma1 per feature (cached); refuses a period too long for the gains."""
        if not (math.isfinite(dt) and dt > 0):
            raise InputError("dt", dt, "a control period > 0 in s")
        longest = self.max_period()
        if dt > longest * (1 + 1e-12):
            raise ConfigError(
                "dt", dt, f"<= {longest:.3g} s (a rate >= {1 / longest:.3g} Hz): the fastest "
                f"compliance mode |s| of M s^2 + D s + K needs |s| dt <= {MAX_POLE_DT}",
            )  # fmt: skip
        phi = np.empty((4, 5))
        gam = np.empty((2, 5))
        for i, (m, d, k) in enumerate(zip(self._m, self._d, self._k, strict=True)):
            # augmented [[A, B], [0, 0]] with A = [[0, 1], [-K/M, -D/M]], B = [0, 1/M]
            aug = np.array([[0.0, 1.0, 0.0], [-k / m, -d / m, 1.0 / m], [0.0, 0.0, 0.0]])
            e = scipy.linalg.expm(aug * dt)
            phi[:, i] = e[0, 0], e[0, 1], e[1, 0], e[1, 1]
            gam[:, i] = e[0, 2], e[1, 2]
        coeffs = np.vstack((phi, gam))
        self._coeffs[dt] = coeffs
        return coeffs
