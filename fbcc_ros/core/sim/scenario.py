"""Scenario files of the closed-loop simulator: schema, defaults, validation (DESIGN §4).

A scenario is a mapping (usually YAML) with these keys; every key but ``geometry`` and
``initial`` has a default:

=============  ========================================================================
geometry       the PegHole fields [m, Pa]: hole_radius, peg_radius, hole_depth,
               base_thickness, friction, stiffness (k of eq. 8; see docs/reproduction.md),
               acting_point (hole_bottom), peg_length (0.05), n_angles (48); rim (false:
               the paper's model, the wall alone; true: the model plant has the top face and
               bottom too, with a compliant holder), chamfer [m] (0; 45°, with rim: MuJoCo's
               scene takes it too)
controller     type: fbcc | admittance | none, or a list of them to compare (default fbcc);
               params: label (Table I, default 3) and any ComplianceParams field
initial        the unknown deviation of the hole: dx, dy [m], theta_x, theta_y [rad]
insertion      depth (default: hole_depth) [m], speed (0.005) [m/s]
sensor         noise: standard deviations of (Fx, Fy, Fz, Mx, My) [N, N·m] or 0
               (default 0.05 N, 0.002 N·m); bias: (Fx, Fy, Fz, Mx, My) (default 0);
               for the ROS cell: source, the wrench the compensation reads (ft_sensor: a
               6-axis sensor under the hole; estimated: the LBR stack's estimate at its
               flange; external_torques | measured_torques: our virtual sensor), and qos, the
               F/T sensor's reliability (reliable | best_effort)
robot          lag: time constant of the position-controlled robot [s] (0.005); delay: how
               long a command takes to reach the robot [s] (0; the simulator rounds it to
               control periods): a cell's drivers and queues, to rehearse against; for the ROS
               cell: model (iiwa14), namespace (''), conventions (fbcc | lbr: the robot
               stack the mock plays) and rate_hz (the stack's rate; sets rate_hz below)
holder         the compliance of arm, sensor and gripper at the grip point (absent: rigid):
               lateral [N/m], angular [N·m/rad] (fbcc_ros/core/sim/holder.py has typical values)
plant          type: model (eq. 5-13, the default) | mujoco (fbcc_ros/core/sim/plants/);
               for mujoco: facets of the bore (128), face_width [m] (0.005, the top face
               around the hole), timestep [s] (5e-5), timeconst [s] (2e-4, metal-like;
               1e-3 plastic-like: the contact's impedance width follows it)
tolerance      success tolerances: offset [m] (2e-5), tilt [rad] (0.0035), depth [m] (1e-5),
               force [N] (1.0): a plane whose lateral force is below it counts as settled
rate_hz        control and simulation rate [Hz] (1000)
duration       simulated time [s] (default: depth / speed + 2)
seed           seed of the sensor noise (0)
=============  ========================================================================

Values that smell of the wrong unit (a radius of 5, a tilt of 2) are refused with the key, the
value and the range we expect in SI units: the check is a plausibility range, not physics.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.control.laws import LAWS, Insertion, Params, params_from_mapping
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.files import read_yaml
from fbcc_ros.core.schema import mapping as _mapping
from fbcc_ros.core.schema import number as _number
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.plants.spec import PlantSpec, plant_spec

#: Plausibility ranges (SI): a value outside smells of mm, degrees or GPa given by mistake.
_LENGTH_MAX = 0.5  # [m] radii and depths of a peg for a robot cell
_OFFSET_MAX = 0.01  # [m] an initial offset of more than 10 mm is not a compliance problem
_TILT_MAX = 0.35  # [rad] 20°
_SPEED_MAX = 0.1  # [m/s]
_STIFFNESS_RANGE = (1e6, 1e12)  # [Pa] foams to steels
_FIT_MAX = 0.05  # |R - r| / R: a fit differs by microns, not by a twentieth of the radius

DEFAULT_NOISE = (0.05, 0.05, 0.05, 0.002, 0.002)  # [N, N·m] a 6-axis F/T sensor's noise
DEFAULT_LAG = 0.005  # [s]
#: The control rates a scenario may state [Hz].
RATE_HZ = (10.0, 1e5)
DEFAULT_TOLERANCE = {"offset": 2e-5, "tilt": 0.0035, "depth": 1e-5, "force": 1.0}


@dataclasses.dataclass(frozen=True)
class Tolerance:
    """What counts as assembled (see :mod:`fbcc_ros.core.sim.simulation`): per plane |d| <= offset
    [m] and |theta| <= tilt [rad], or the lateral force <= force [N]; the depth within ``depth``
    [m] of the final depth."""

    offset: float = DEFAULT_TOLERANCE["offset"]
    tilt: float = DEFAULT_TOLERANCE["tilt"]
    depth: float = DEFAULT_TOLERANCE["depth"]
    force: float = DEFAULT_TOLERANCE["force"]


#: The wrench sources the ROS cell can use, and the F/T sensor's reliabilities.
SOURCES = ("ft_sensor", "estimated", "external_torques", "measured_torques")
CONVENTIONS = ("fbcc", "lbr")
_NAMESPACE = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)*")


@dataclasses.dataclass(frozen=True)
class RosCell:
    """The robot stack the ROS cell rehearses (``fbcc_bringup``; the simulator models the
    contact, not the stack): the arm's model, the namespace and conventions of its stack, the
    wrench source the compensation reads and the F/T sensor's reliability."""

    model: str = "iiwa14"
    namespace: str = ""
    conventions: str = "fbcc"
    source: str = "ft_sensor"
    qos: str = "reliable"


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A validated scenario (see the module doc for the keys)."""

    geometry: PegHole
    laws: tuple[str, ...]
    params: Params
    initial: FloatArray  # the hole's unknown deviation as features (dx, dy, 0, theta_x, theta_y)
    insertion: Insertion
    noise: FloatArray
    bias: FloatArray
    lag: float
    tolerance: Tolerance
    rate_hz: float
    duration: float
    seed: int
    name: str = "scenario"
    holder: Holder | None = None  # None: the peg held rigidly
    cell: RosCell = RosCell()
    delay: float = 0.0  # [s] from a command to the robot (robot.delay)
    plant: PlantSpec = dataclasses.field(default_factory=PlantSpec)

    @property
    def law(self) -> str:
        """The single law of a one-law scenario."""
        if len(self.laws) != 1:
            raise ConfigError("controller.type", list(self.laws), "a single law here")
        return self.laws[0]

    def with_law(self, law: str) -> Scenario:
        return dataclasses.replace(self, laws=(law,))

    def on_plant(self, kind: str) -> Scenario:
        return dataclasses.replace(self, plant=dataclasses.replace(self.plant, type=kind))

    @property
    def steps(self) -> int:
        return round(self.duration * self.rate_hz)


def _vector5(key: str, value: Any, limit: float, unit: str) -> FloatArray:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0:
        return np.zeros(5)
    if not isinstance(value, (list, tuple)) or len(value) != 5:
        raise ConfigError(
            key, value, f"0 or a list of five numbers (Fx, Fy, Fz, Mx, My) in {unit}"
        )
    return np.array([_number(f"{key}[{i}]", v, -limit, limit, unit) for i, v in enumerate(value)])


def _geometry(value: Any) -> PegHole:
    fields = ("hole_radius", "peg_radius", "hole_depth", "base_thickness", "friction",
              "stiffness", "acting_point", "peg_length", "n_angles", "rim", "chamfer")  # fmt: skip
    g = _mapping("geometry", value, fields, fields[:6])
    kw: dict[str, Any] = {}
    for name in ("hole_radius", "peg_radius", "hole_depth", "peg_length"):
        if name in g:
            kw[name] = _number(f"geometry.{name}", g[name], 0, _LENGTH_MAX, "m", low_open=True)
    kw["base_thickness"] = _number(
        "geometry.base_thickness", g["base_thickness"], 0, _LENGTH_MAX, "m"
    )
    kw["friction"] = _number("geometry.friction", g["friction"], 0, 1, "(dimensionless, < 1)")
    kw["stiffness"] = _number("geometry.stiffness", g["stiffness"], *_STIFFNESS_RANGE, "Pa")
    for name in ("acting_point", "n_angles", "rim"):
        if name in g:
            kw[name] = g[name]
    if "chamfer" in g:
        kw["chamfer"] = _number("geometry.chamfer", g["chamfer"], 0, _LENGTH_MAX, "m")
    fit = abs(kw["hole_radius"] - kw["peg_radius"]) / kw["hole_radius"]
    if fit > _FIT_MAX:
        raise ConfigError(
            "geometry.peg_radius", g["peg_radius"],
            f"within {_FIT_MAX:.0%} of hole_radius={g['hole_radius']} m: a clearance or "
            "interference fit differs by microns (are both in m?)",
        )  # fmt: skip
    try:
        return PegHole(**kw)
    except ConfigError as exc:
        raise ConfigError(f"geometry.{exc.field}", exc.value, exc.allowed) from None


def _laws(value: Any) -> tuple[str, ...]:
    names = value if isinstance(value, list) else [value]
    for name in names:
        if name not in LAWS:
            raise ConfigError(
                "controller.type", value, f"one of {', '.join(LAWS)} or a list of them"
            )
    if not names or len(set(names)) != len(names):
        raise ConfigError("controller.type", value, "one law, or a list of distinct laws")
    return tuple(names)


def validate(scenario: Any, name: str = "scenario") -> Scenario:
    """Check a scenario mapping and fill in the defaults; raises ConfigError naming the key."""
    top = ("geometry", "controller", "initial", "insertion", "sensor", "robot", "holder",
           "plant", "tolerance", "rate_hz", "duration", "seed")  # fmt: skip
    s = _mapping("scenario", scenario, top, ("geometry", "initial"))
    geometry = _geometry(s["geometry"])

    c = _mapping("controller", s.get("controller", {}), ("type", "params"))
    laws = _laws(c.get("type", "fbcc"))
    params_in = c.get("params", {})
    if not isinstance(params_in, Mapping):
        raise ConfigError("controller.params", params_in, "a mapping of Table I gains")
    params = params_from_mapping(params_in, "controller.params")

    i = _mapping("initial", s["initial"], ("dx", "dy", "theta_x", "theta_y"),
                 ("dx", "dy", "theta_x", "theta_y"))  # fmt: skip
    initial = np.array([
        _number("initial.dx", i["dx"], -_OFFSET_MAX, _OFFSET_MAX, "m"),
        _number("initial.dy", i["dy"], -_OFFSET_MAX, _OFFSET_MAX, "m"),
        0.0,
        _number("initial.theta_x", i["theta_x"], -_TILT_MAX, _TILT_MAX, "rad"),
        _number("initial.theta_y", i["theta_y"], -_TILT_MAX, _TILT_MAX, "rad"),
    ])  # fmt: skip

    ins = _mapping("insertion", s.get("insertion", {}), ("depth", "speed"))
    depth = _number(
        "insertion.depth", ins.get("depth", geometry.hole_depth), 0, geometry.hole_depth,
        "m (at most geometry.hole_depth)", low_open=True,
    )  # fmt: skip
    speed = _number("insertion.speed", ins.get("speed", 5e-3), 0, _SPEED_MAX, "m/s", low_open=True)
    insertion = Insertion(depth, speed)

    sen = _mapping("sensor", s.get("sensor", {}), ("noise", "bias", "source", "qos"))
    noise = _vector5("sensor.noise", sen.get("noise", list(DEFAULT_NOISE)), 100, "N, N·m")
    if np.any(noise < 0):
        raise ConfigError("sensor.noise", sen["noise"], "standard deviations >= 0")
    bias = _vector5("sensor.bias", sen.get("bias", 0), 1000, "N, N·m")

    rob = _mapping("robot", s.get("robot", {}),
                   ("lag", "delay", "model", "namespace", "conventions", "rate_hz"))  # fmt: skip
    lag = _number("robot.lag", rob.get("lag", DEFAULT_LAG), 0, 1, "s")
    delay = _number("robot.delay", rob.get("delay", 0.0), 0, 1, "s")
    cell = _ros_cell(rob, sen)

    holder = None
    if "holder" in s:
        h = _mapping("holder", s["holder"], ("lateral", "angular"), ("lateral", "angular"))
        holder = Holder(_number("holder.lateral", h["lateral"], 0, 1e12, "N/m", low_open=True),
                        _number("holder.angular", h["angular"], 0, 1e9, "N·m/rad",
                                low_open=True))  # fmt: skip

    tol = _mapping("tolerance", s.get("tolerance", {}), tuple(DEFAULT_TOLERANCE))
    tolerance = Tolerance(
        _number(
            "tolerance.offset",
            tol.get("offset", Tolerance.offset),
            0,
            _OFFSET_MAX,
            "m",
            low_open=True,
        ),
        _number(
            "tolerance.tilt", tol.get("tilt", Tolerance.tilt), 0, _TILT_MAX, "rad", low_open=True
        ),
        _number(
            "tolerance.depth", tol.get("depth", Tolerance.depth), 0, depth, "m", low_open=True
        ),
    )

    rate = _number("rate_hz", s.get("rate_hz", 1000), *RATE_HZ, "Hz")
    if "rate_hz" in rob:
        stack = _number("robot.rate_hz", rob["rate_hz"], *RATE_HZ, "Hz")
        if "rate_hz" in s and stack != rate:
            raise ConfigError("robot.rate_hz", stack, f"the scenario's rate_hz ({rate:g} Hz) "
                              "or only one of the two")  # fmt: skip
        rate = stack
    duration = _number(
        "duration", s.get("duration", depth / speed + 2.0), 0, 3600, "s", low_open=True
    )
    if duration * rate < 10:
        raise ConfigError("duration", duration, f">= {10 / rate:g} s: at least 10 control periods")
    seed = s.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError("seed", seed, "an integer >= 0")
    plant = plant_spec(s.get("plant", {}), rate)
    if geometry.chamfer >= plant.face_width:  # MuJoCo's top face holds the chamfer
        raise ConfigError("geometry.chamfer", geometry.chamfer,
                          f"less than plant.face_width ({plant.face_width:g} m)")  # fmt: skip
    return Scenario(geometry, laws, params, initial, insertion, noise, bias, lag, tolerance,
                    rate, duration, seed, name, holder, cell, delay, plant)  # fmt: skip


def _choice(key: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ConfigError(key, value, f"one of {list(choices)}")
    return str(value)


def _ros_cell(robot: Mapping[str, Any], sensor: Mapping[str, Any]) -> RosCell:
    """The robot and sensor keys of the ROS cell (module doc), checked together."""
    from fbcc_ros.core.kinematics.robot import LBRS, ROBOTS

    model = _choice("robot.model", robot.get("model", "iiwa14"), tuple(ROBOTS))
    conventions = _choice("robot.conventions", robot.get("conventions", "fbcc"), CONVENTIONS)
    namespace = robot.get("namespace", "")
    if not isinstance(namespace, str) or not _NAMESPACE.fullmatch(namespace):
        raise ConfigError("robot.namespace", namespace, "'' or a ROS namespace such as /lbr")
    source = _choice("sensor.source", sensor.get("source", "ft_sensor"), SOURCES)
    qos = _choice("sensor.qos", sensor.get("qos", "reliable"), ("reliable", "best_effort"))
    if conventions == "lbr" and model not in LBRS:
        raise ConfigError("robot.model", model, "an LBR (iiwa7, iiwa14, med7, med14) with "
                          "conventions lbr")  # fmt: skip
    if source == "estimated" and conventions != "lbr":
        raise ConfigError("sensor.source", source, "robot.conventions lbr with it (the LBR "
                          "stack's estimated wrench)")  # fmt: skip
    return RosCell(model, namespace, conventions, source, qos)


def load(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    p = Path(path)
    return validate(read_yaml(p, "scenario file"), p.stem)


def find(value: str) -> Path:
    """The scenario file ``value`` names: a path as given, else relative to the package's share
    directory (an installed package), else to the source checkout."""
    path = Path(value)
    if path.is_file():
        return path
    try:
        from ament_index_python.packages import get_package_share_directory

        shared = Path(get_package_share_directory("fbcc_ros")) / value
        if shared.is_file():
            return shared
    except (ImportError, LookupError, KeyError, ValueError, OSError):
        pass
    package = Path(__file__).resolve().parents[3] / value  # a source checkout
    if package.is_file():
        return package
    raise ConfigError("scenario", value, "the path of a scenario YAML (DESIGN §4)")
