"""Peg-hole geometry and the contact model of the paper (Section II.B, eq. 5-13).

Geometry (DESIGN §3, and the reading of eq. 5 written down in ``docs/contact-model.md``):

* Frame {H}: origin at the centre of the hole's top face, z along the hole axis pointing out of
  the hole. The hole wall is the cylinder ``x² + y² = R²`` for ``-L <= z <= 0`` (eq. 6).
* Features ``(dx, dy, l, theta_x, theta_y)``. ``theta_x``, ``theta_y`` are the projected tilts of
  the peg axis (right-hand rotations about x and y; eq. 3 read with eq. 14), so the axis leans by
  ``t = (tan theta_y, -tan theta_x)`` horizontally per unit of height. The total tilt is
  ``tan theta = |t|`` and the lean direction is ``e = t / |t|``, the paper's
  ``(cos phi, sin phi)``.
* Slices (eq. 5): ``s`` is the height above the peg's lowest point, from ``s_l = 0`` to the top
  face ``s_u = l cos theta``. The slice of the peg at ``s`` is the ellipse of eq. 7, rotated to
  the lean direction (semi-axis ``r / cos theta`` along ``e``, ``r`` across), centred at

      O_p(s) = (dx, dy) - (l/2 + r sin theta - s / cos theta) sin theta · e.          (5)

* Contact (eq. 8): along the half-line from the hole axis at angle alpha, the peg's outline lies
  at distance ``rho = O_hG``; the wall pressure is ``p = k (rho - R) / R`` where ``rho >= R``.

Quadrature: for each ray alpha the contact interval in s is found exactly (the wall point
``R (cos alpha, sin alpha)`` lies inside the slice ellipse on an interval of s, because the slice
centre moves linearly in s), and the smooth penetration ``rho - R`` is integrated over that
interval by Gauss-Legendre. Only the outer integral over alpha is a uniform (periodic) rule.
The accuracy against a brute-force 2-D quadrature of eq. 9-13 is pinned in
``test/core/contact/test_model.py``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.kernel import WORK_ROWS, angle_table, response_kernel
from fbcc_ros.core.contact.rim import RAYS_PER_WALL_RAY, rim_kernel
from fbcc_ros.core.contact.sliding import SLIDE, as_slide, wall_friction_kernel
from fbcc_ros.core.errors import ConfigError, InputError

#: Order of the features in every feature vector: (dx, dy, l, theta_x, theta_y).
FEATURE_NAMES = ("dx", "dy", "l", "theta_x", "theta_y")
#: Order of the responses in every response vector: (Fx, Fy, Fz, Mx, My).
RESPONSE_NAMES = ("Fx", "Fy", "Fz", "Mx", "My")

#: Young's modulus [Pa] and Poisson's ratio of ABS, the paper's material (datasheet values).
ABS_YOUNG = 2.2e9
ABS_POISSON = 0.35

ActingPoint = Literal["hole_bottom", "peg_top"]
_ACTING_POINTS = ("hole_bottom", "peg_top")


def lame_stiffness(
    hole_radius: float,
    outer_radius: float,
    young_peg: float = ABS_YOUNG,
    poisson_peg: float = ABS_POISSON,
    young_hole: float = ABS_YOUNG,
    poisson_hole: float = ABS_POISSON,
) -> float:
    """The coefficient k of eq. (8) from Lamé's thick-walled cylinder solution [Pa].

    A solid peg pressed into a thick-walled cylinder (inner radius R, outer radius b) by a radial
    interference delta carries the contact pressure (shrink-fit formula, e.g. Shigley §3-16)

    .. math::
        \\delta = p R \\left[\\frac{1}{E_h}\\left(\\frac{b^2 + R^2}{b^2 - R^2} + \\nu_h\\right)
                 + \\frac{1 - \\nu_p}{E_p}\\right],

    and eq. (8) writes ``p = k delta / R``, so

    .. math::
        k = \\left[\\frac{1}{E_h}\\left(\\frac{b^2 + R^2}{b^2 - R^2} + \\nu_h\\right)
            + \\frac{1 - \\nu_p}{E_p}\\right]^{-1}.

    Args:
        hole_radius: R [m].
        outer_radius: b, outer radius of the part that holds the hole [m], > R.
        young_peg, young_hole: Young's moduli [Pa].
        poisson_peg, poisson_hole: Poisson's ratios, in [0, 0.5).
    """
    _check_positive("hole_radius", hole_radius)
    _check_positive("young_peg", young_peg)
    _check_positive("young_hole", young_hole)
    for name, nu in (("poisson_peg", poisson_peg), ("poisson_hole", poisson_hole)):
        if not (math.isfinite(nu) and 0.0 <= nu < 0.5):
            raise ConfigError(name, nu, "a Poisson's ratio in [0, 0.5)")
    if not (math.isfinite(outer_radius) and outer_radius > hole_radius):
        raise ConfigError(
            "outer_radius", outer_radius, f"a length in m greater than hole_radius={hole_radius}"
        )
    b2, r2 = outer_radius**2, hole_radius**2
    hole_term = ((b2 + r2) / (b2 - r2) + poisson_hole) / young_hole
    compliance = hole_term + (1.0 - poisson_peg) / young_peg
    return 1.0 / compliance


def as_rows(values: ArrayLike, field: str, finite_as: str) -> tuple[FloatArray, bool]:
    """Validate feature or response vectors: shape (5,) or (N, 5), all finite.

    Returns the rows as (N, 5) and whether a single vector was given. ``finite_as`` says in the
    error message what finite values were expected.
    """
    a = np.asarray(values, dtype=float)
    single = a.ndim == 1
    rows = a.reshape(1, -1) if single else a
    if rows.ndim != 2 or rows.shape[1] != 5:
        raise InputError(field, f"array of shape {a.shape}", "shape (5,) or (N, 5)")
    if not np.isfinite(rows).all():
        bad = rows[~np.isfinite(rows).all(axis=1)][0]
        raise InputError(field, bad.tolist(), f"finite {finite_as}")
    return rows, single


def _check_positive(field: str, value: float) -> None:
    if not (isinstance(value, (int, float, np.floating)) and math.isfinite(value) and value > 0):
        raise ConfigError(field, value, "a finite number > 0 (SI units)")


@dataclasses.dataclass(frozen=True)
class PegHole:
    """A cylindrical peg and hole, and the contact model of eq. (5)-(13).

    Attributes:
        hole_radius: R [m].
        peg_radius: r [m]. ``r < R`` is a clearance fit, ``r > R`` an interference fit.
        hole_depth: L, depth of the hole [m].
        base_thickness: H, thickness of the hole's bottom layer [m] (the sensor sits under it).
        friction: mu, Coulomb friction coefficient between peg and hole, in [0, 1).
        stiffness: k of eq. (8) [Pa]; see :func:`lame_stiffness` and :meth:`from_materials`.
        acting_point: Where the moments are taken. ``"hole_bottom"`` (default): the centre of the
            hole's lower surface, L + H below the top face (eq. 12-13). ``"peg_top"``: the centre
            of the peg's top face, ``peg_length`` along the axis from the tip (Remark 2 of II.B,
            the wrist-sensor placement of the paper's experiment).
        peg_length: Length of the peg from its tip to its top face [m]; used by ``"peg_top"``.
        n_angles: Points of the periodic rule over alpha (a multiple of 4, so that the rule is
            symmetric under 90° rotations about z).
        rim: Whether the hole block is solid around and under the bore: its top face, the
            chamfer and the bottom press on the peg's end face (:mod:`.rim`), and the wall's
            friction opposes the peg's sliding (:mod:`.sliding`). False: the paper's model,
            the wall alone (a peg beside the hole touches nothing).
        chamfer: W, the width of the hole's 45° chamfer [m] (0: a sharp edge); only with
            ``rim``.
    """

    hole_radius: float
    peg_radius: float
    hole_depth: float
    base_thickness: float
    friction: float
    stiffness: float
    acting_point: ActingPoint = "hole_bottom"
    peg_length: float = 0.05
    n_angles: int = 48
    rim: bool = False
    chamfer: float = 0.0

    def __post_init__(self) -> None:
        _check_positive("hole_radius", self.hole_radius)
        _check_positive("peg_radius", self.peg_radius)
        _check_positive("hole_depth", self.hole_depth)
        _check_positive("stiffness", self.stiffness)
        if not (math.isfinite(self.base_thickness) and self.base_thickness >= 0):
            raise ConfigError("base_thickness", self.base_thickness, "a finite length >= 0 in m")
        if not (math.isfinite(self.friction) and 0.0 <= self.friction < 1.0):
            raise ConfigError("friction", self.friction, "a friction coefficient in [0, 1)")
        if self.acting_point not in _ACTING_POINTS:
            raise ConfigError("acting_point", self.acting_point, f"one of {_ACTING_POINTS}")
        if self.acting_point == "peg_top":
            _check_positive("peg_length", self.peg_length)
        if not (isinstance(self.n_angles, int) and self.n_angles >= 8 and self.n_angles % 4 == 0):
            raise ConfigError("n_angles", self.n_angles, "an integer >= 8 that is a multiple of 4")
        if not isinstance(self.rim, bool):
            raise ConfigError("rim", self.rim, "true or false")
        if not (math.isfinite(self.chamfer) and 0.0 <= self.chamfer < self.hole_depth):
            raise ConfigError("chamfer", self.chamfer,
                              f"a width in m in [0, hole_depth {self.hole_depth:g})")  # fmt: skip
        if self.chamfer > 0 and not self.rim:
            raise ConfigError("chamfer", self.chamfer, "0 without the rim (rim: false has no "
                              "top face to chamfer)")  # fmt: skip

    @classmethod
    def from_materials(
        cls,
        hole_radius: float,
        peg_radius: float,
        hole_depth: float,
        base_thickness: float,
        friction: float,
        outer_radius: float,
        young_peg: float = ABS_YOUNG,
        poisson_peg: float = ABS_POISSON,
        young_hole: float = ABS_YOUNG,
        poisson_hole: float = ABS_POISSON,
        **kwargs: object,
    ) -> PegHole:
        """A PegHole whose k of eq. (8) comes from :func:`lame_stiffness` (ABS by default)."""
        k = lame_stiffness(
            hole_radius, outer_radius, young_peg, poisson_peg, young_hole, poisson_hole
        )
        return cls(hole_radius, peg_radius, hole_depth, base_thickness, friction, k, **kwargs)  # type: ignore[arg-type]

    @property
    def fit(self) -> str:
        """``"clearance"`` when r < R, else ``"interference"`` (r == R counts as interference)."""
        return "clearance" if self.peg_radius < self.hole_radius else "interference"

    def acting_point_in_hole(self) -> FloatArray:
        """Where the response's moments are taken, in {H} [m]: for ``"hole_bottom"`` the centre
        of the hole's lower surface, ``(0, 0, -(L + H))`` (eq. 12-13). The one definition the
        compensation, the mock cell and the bringup use. ``"peg_top"`` moves with the peg, so
        it has no fixed point in {H}: refused, naming the cause (the ROS cell's compensation
        gives moments about a point fixed in {H}; the simulator takes ``"peg_top"``)."""
        if self.acting_point != "hole_bottom":
            raise ConfigError("geometry.acting_point", self.acting_point, "'hole_bottom' here: "
                              "'peg_top' moves with the peg, and the ROS cell's compensation "
                              "gives moments about a point fixed in {H} (the simulator takes "
                              "'peg_top')")  # fmt: skip
        return np.array([0.0, 0.0, -(self.hole_depth + self.base_thickness)])

    def replace(self, **changes: object) -> PegHole:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[arg-type]

    def boundary_lever(self, depth: ArrayLike) -> FloatArray:
        """Slope My/Fx of the image of theta_y = 0 in response space [m] (eq. 23-24).

        With no tilt every slice carries the same pressure, so My/Fx is the mean lever of the
        contact band over the acting point plus the friction arm mu R. For the default acting
        point this is eq. (24), ``-l/2 + L + H + mu R``; for ``"peg_top"`` the acting point is
        ``peg_length - l`` above the top face and the lever is ``l/2 - peg_length + mu R``.
        Depths beyond L are clamped to L: below the hole there is no wall.
        """
        l = np.asarray(depth, dtype=float)
        base, per_depth = self.lever_terms()
        return base - np.minimum(l, self.hole_depth) / 2.0 + per_depth * l  # type: ignore[no-any-return]

    def lever_terms(self) -> tuple[float, float]:
        """``(base, per_depth)`` with ``lever(l) = base - min(l, L)/2 + per_depth l`` (see
        :meth:`boundary_lever`; the controller's compiled step takes them as numbers)."""
        mu_r = self.friction * self.hole_radius
        if self.acting_point == "hole_bottom":
            # eq. (24): My / Fx = -l/2 + L + H + mu R
            return self.hole_depth + self.base_thickness + mu_r, 0.0
        # acting point at z_A = peg_length - l; mean contact height -l_wall/2
        return mu_r - self.peg_length, 1.0

    def push_in_force(self, depth: float | None = None) -> float:
        """The quasi-static axial force of a centred, aligned peg at ``depth`` (default L) [N]:
        eq. 8 with the uniform penetration delta = r - R all round, eq. 11:
        ``Fz = mu 2 pi delta l k`` (0 for a clearance fit). No controller inserts below it."""
        l = self.hole_depth if depth is None else min(depth, self.hole_depth)
        delta = max(self.peg_radius - self.hole_radius, 0.0)
        # eq. (11) with p = k delta / R over the band 2 pi R l
        return self.friction * 2.0 * math.pi * delta * l * self.stiffness

    def response(self, features: ArrayLike, slide: ArrayLike | None = None) -> FloatArray:
        """Responses (Fx, Fy, Fz, Mx, My) for features (dx, dy, l, theta_x, theta_y).

        Implements eq. (5)-(13) of the paper. The wrench is the one the peg exerts on the hole,
        in {H}, with moments at the acting point. Signs (DESIGN §3): Fx, Fy, Mx, My follow the
        right-hand rule, so ``Mx = -(eq. 12)``; ``Fz`` is eq. (11), the axial friction resultant,
        positive while the peg is pushed in (it drags the hole along -z; the moment arms ``mu R``
        of eq. 12-13 come from that friction).

        With the rim, the top face, the chamfer and the bottom add their wrench
        (:mod:`.rim`), a negative depth (the peg above the hole) is allowed, and the wall's
        friction opposes the peg's own sliding instead of eq. 11's push (:mod:`.sliding`).

        Args:
            features: shape (5,) or (N, 5); lengths in m, angles in rad; depth l >= 0
                without the rim.
            slide: The peg's velocity in {H}, shape (5,) or (N, 5): its tip centre's
                (vx, vy, vz) [m/s] and its turn (ωx, ωy) [rad/s] (:mod:`.sliding`); 3 columns:
                no turn. For the friction of a pair with the rim, on its faces and its wall
                (None: at rest, no friction).

        Returns:
            Responses of the same shape; forces in N, moments in N·m. A depth of zero, or a
            peg that touches no wall, gives an exactly zero wrench without the rim.
        """
        f2, single = as_rows(features, "features", "(dx, dy, l, theta_x, theta_y)")
        if not self.rim and (f2[:, 2] < 0).any():
            bad_l = float(f2[f2[:, 2] < 0, 2][0])
            raise InputError("features.l", bad_l, "an insertion depth >= 0 in m (the model "
                             "without the rim has nothing above the hole)")  # fmt: skip
        v = None if slide is None else np.asarray(slide, dtype=float)
        if v is not None:
            v = v.reshape(1, -1) if v.ndim == 1 else v
        if v is not None and (v.shape not in ((len(f2), 3), (len(f2), SLIDE))
                              or not np.isfinite(v).all()):  # fmt: skip
            raise InputError("slide", np.asarray(slide).tolist(), "finite velocities (vx, vy, "
                             "vz[, wx, wy]) in m/s and rad/s, one per feature row")  # fmt: skip
        out = self._batch.response(f2, v)
        return out[0] if single else out

    @functools.cached_property
    def _batch(self) -> ContactBatch:
        return ContactBatch.of([self])


@dataclasses.dataclass(frozen=True, eq=False)
class ContactBatch:
    """Several peg-hole pairs evaluated in one call, one pair per feature row.

    The closed-loop simulator steps a whole Monte Carlo batch at once, each trial with its own
    manufacturing tolerances. Build it with :meth:`of`; a batch of one pair serves any number of
    rows (that is what :meth:`PegHole.response` uses).

    Attributes:
        table: (TABLE_ROWS, N) rows R, r, mu, k, L, H, peg_length, chamfer [SI] and rim (1.0
            or 0.0), one column per pair.
        peg_top: Whether the moments are taken at the peg's top face (else the hole bottom).
        n_angles: Points of the periodic rule over alpha.
    """

    table: FloatArray
    peg_top: bool
    n_angles: int

    @classmethod
    def of(cls, pegholes: Sequence[PegHole]) -> ContactBatch:
        """The batch of the given pairs; they must share the acting point and the rule."""
        if not pegholes:
            raise ConfigError("pegholes", [], "at least one PegHole")
        first = pegholes[0]
        for ph in pegholes:
            if (ph.acting_point, ph.n_angles) != (first.acting_point, first.n_angles):
                raise ConfigError(
                    "pegholes",
                    f"acting_point={ph.acting_point}, n_angles={ph.n_angles}",
                    f"the same as the first pair ({first.acting_point}, {first.n_angles})",
                )
        table = np.array(
            [
                [
                    ph.hole_radius,
                    ph.peg_radius,
                    ph.friction,
                    ph.stiffness,
                    ph.hole_depth,
                    ph.base_thickness,
                    ph.peg_length,
                    ph.chamfer,
                    float(ph.rim),
                ]
                for ph in pegholes
            ]
        ).T.copy()
        return cls(table, first.acting_point == "peg_top", first.n_angles)

    def __len__(self) -> int:
        return int(self.table.shape[1])

    def response(self, features: FloatArray, slide: FloatArray | None = None) -> FloatArray:
        """eq. (5)-(13), and the rim where a pair has it, for validated rows of shape (N, 5):
        row i uses pair i (or the only one); ``slide`` (N, 3 or :data:`~.sliding.SLIDE`) the
        pegs' velocities (None: at rest), for the friction where a pair has the rim.

        No validation here: this is the simulator's inner loop. :meth:`PegHole.response` is the
        checked entry point.
        """
        if len(self) not in (1, len(features)):
            raise InputError(
                "features", f"{len(features)} rows", f"{len(self)} rows, one per pair"
            )
        ca, sa = angle_table(self.n_angles)
        out = np.empty((len(features), 5))
        f = np.ascontiguousarray(features, dtype=float)
        work = np.empty((WORK_ROWS, len(f)))
        response_kernel(f, self.table, self.peg_top, ca, sa, out, work)
        if self.has_rim:
            v = as_slide(slide, len(f))  # a peg at rest where none is given
            rim_ca, rim_sa = angle_table(RAYS_PER_WALL_RAY * self.n_angles)
            rim_kernel(f, v, self.table, self.peg_top, rim_ca, rim_sa, out)
            wall_friction_kernel(f, v, self.table, self.peg_top, ca, sa, out, work)
        return out

    @functools.cached_property
    def has_rim(self) -> bool:
        """Whether any pair has the rim (:attr:`PegHole.rim`)."""
        return bool((self.table[8] > 0).any())
