"""A scenario's ``plant`` section: which plant, and the MuJoCo scene's bore, timestep and
contact time constant. Checked here, without MuJoCo, so that a bad key is refused before any
trial runs."""

from __future__ import annotations

import dataclasses
from typing import Any

from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.schema import mapping, number

PLANTS = ("model", "mujoco")  # the plants a scenario may run on
#: The largest MuJoCo timestep [s] a scene runs at; its grip's armature is sized for it
#: (:data:`.mujoco_scene.STABLE`), so a smaller timestep refines the same dynamics.
MAX_TIMESTEP = 1.0e-4
#: The fewest timesteps in the contact's time constant (``solref``). MuJoCo asks for two; at
#: two a chamfered insertion's peak force moved 5.5 % when the timestep was halved, at four
#: 1.8 % (docs/plant.md).
TIMESTEPS_PER_TIMECONST = 4
#: The default timestep [s]: four in the metal-like contact's 0.2 ms (docs/plant.md).
TIMESTEP = 5.0e-5
#: The softest contact a scenario may ask for: solref's time constant [s].
MAX_TIMECONST = 0.01


@dataclasses.dataclass(frozen=True)
class PlantSpec:
    """The scenario's ``plant`` (module doc); the defaults are the scene's."""

    type: str = "model"
    facets: int = 128
    face_width: float = 0.005
    timestep: float = TIMESTEP
    timeconst: float = TIMESTEPS_PER_TIMECONST * TIMESTEP


def plant_spec(value: Any, rate: float) -> PlantSpec:
    """The ``plant`` section, checked against the control rate ``rate`` [Hz]."""
    if isinstance(value, dict) and "chamfer" in value:
        raise ConfigError("plant.chamfer", value["chamfer"],
                          "geometry.chamfer, with geometry.rim: true: the part's chamfer, "
                          "which both plants take")  # fmt: skip
    p = mapping("plant", value, tuple(f.name for f in dataclasses.fields(PlantSpec)))
    kind = p.get("type", "model")
    if kind not in PLANTS:
        raise ConfigError("plant.type", kind, f"one of {list(PLANTS)}")
    facets = p.get("facets", PlantSpec.facets)
    if isinstance(facets, bool) or not isinstance(facets, int) or not 16 <= facets <= 4096:
        raise ConfigError("plant.facets", facets, "an integer in [16, 4096]")
    width = number("plant.face_width", p.get("face_width", PlantSpec.face_width), 0, 0.1, "m",
                   low_open=True)  # fmt: skip
    timestep = number("plant.timestep", p.get("timestep", PlantSpec.timestep), 0,
                      MAX_TIMESTEP, "s", low_open=True)  # fmt: skip
    periods = 1.0 / (rate * timestep)
    if abs(periods - round(periods)) > 1e-6:
        raise ConfigError("plant.timestep", timestep, f"a whole fraction of the control period "
                          f"({1 / rate:g} s)")  # fmt: skip
    least = TIMESTEPS_PER_TIMECONST * timestep
    timeconst = number("plant.timeconst", p.get("timeconst", PlantSpec.timeconst), least,
                       MAX_TIMECONST,
                       f"s (at least {TIMESTEPS_PER_TIMECONST} timesteps)")  # fmt: skip
    return PlantSpec(kind, facets, width, timestep, timeconst)
