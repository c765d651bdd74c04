"""Robustness at scale: many assemblies with random deviations, tolerances and materials.

Each trial draws

* the hole's unknown deviation: dx, dy uniform in ±max_offset, theta_x, theta_y uniform in
  ±max_tilt (defaults ±0.1 mm, ±2°, as the paper's experiment and Section IV.C);
* the true radii: each of R and r moves uniformly within ± half the range of the diameters
  measured in one group of Table II, the group drawn per trial (:func:`mapping_study.perturbed`);
* optionally the material: eq. 8's k log-uniform in ``stiffness`` = (low, high) [Pa] and mu
  uniform in ``friction`` = (low, high); by default both stay nominal.

A part whose quasi-static push-in force (:meth:`PegHole.push_in_force` at L) exceeds
``feasible_force`` cannot be inserted by any controller within the force limit; when
``feasible_force`` is given such a part is drawn again (its deviations kept) and counted in
:attr:`Trials.redrawn`, so that the study measures the controller, not the impossible.

Every law sees the same trials (same seed). The trials are split in batches that run in lockstep
(:func:`simulation.simulate`) on a pool of local processes or on a Dask cluster
(:mod:`fbcc_ros.core.sim.parallel`); batch j's sensor noise is seeded with ``scenario.seed + j``,
so a trial's outcome depends only on the seeds, not on where or on how many workers it ran.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.mapping_study import perturbed
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.parallel import run_tasks
from fbcc_ros.core.sim.scenario import Scenario
from fbcc_ros.core.sim.simulation import Outcome, SimResult, Trajectory, simulate, state_sequence

DEFAULT_MAX_OFFSET = 1e-4  # [m]
DEFAULT_MAX_TILT = math.radians(2.0)  # [rad]
#: Trials per lockstep batch (and per task of the pool).
BATCH = 128


@dataclasses.dataclass(frozen=True)
class Trials:
    """The random part of N trials: deviations (N, 5), true geometries, and how many parts were
    drawn again because they could not be inserted (see the module doc)."""

    initial: FloatArray
    geometries: tuple[PegHole, ...]
    redrawn: int = 0

    def __len__(self) -> int:
        return len(self.initial)

    def part(self, s: slice) -> Trials:
        return Trials(self.initial[s], self.geometries[s])


def draw_trials(
    nominal: PegHole,
    n: int,
    seed: int,
    max_offset: float = DEFAULT_MAX_OFFSET,
    max_tilt: float = DEFAULT_MAX_TILT,
    *,
    stiffness: tuple[float, float] | None = None,
    friction: tuple[float, float] | None = None,
    feasible_force: float | None = None,
) -> Trials:
    """N random trials around the nominal pair (see the module doc).

    Args:
        stiffness: (low, high) of a log-uniform k [Pa]; None keeps the nominal k.
        friction: (low, high) of a uniform mu; None keeps the nominal mu.
        feasible_force: Largest quasi-static push-in force at L [N] of a part kept; None keeps
            every part.
    """
    if not (isinstance(n, int) and n >= 1):
        raise ConfigError("trials", n, "an integer >= 1")
    for name, bounds, low in (("stiffness", stiffness, 0.0), ("friction", friction, 0.0)):
        if bounds is not None and not (low < bounds[0] <= bounds[1]):
            raise ConfigError(name, list(bounds), f"(low, high) with {low:g} < low <= high")
    rng = np.random.default_rng(seed)
    initial = np.zeros((n, 5))
    initial[:, :2] = rng.uniform(-max_offset, max_offset, (n, 2))
    initial[:, 3:] = rng.uniform(-max_tilt, max_tilt, (n, 2))
    geometries: list[PegHole] = []
    redrawn = 0
    while len(geometries) < n:
        g = perturbed(nominal, rng, friction_spread=0.0, stiffness_octaves=0.0)
        if stiffness is not None:
            k = 10.0 ** rng.uniform(math.log10(stiffness[0]), math.log10(stiffness[1]))
            g = g.replace(stiffness=float(k))
        if friction is not None:
            g = g.replace(friction=float(rng.uniform(*friction)))
        if feasible_force is not None and g.push_in_force() > feasible_force:
            redrawn += 1
            if redrawn > 100 * n:
                raise ConfigError(
                    "feasible_force", feasible_force,
                    "a force most drawn parts can be pushed in with (100 draws per trial "
                    "were all too tight: is the fit an interference too stiff to insert?)",
                )  # fmt: skip
            continue
        geometries.append(g)
    return Trials(initial, tuple(geometries), redrawn)


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """95 % Wilson score interval of a success rate (honest at 0 % and 100 %, unlike Wald)."""
    if n <= 0:
        return math.nan, math.nan
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def _run_part(sc: Scenario, law: str, trials: Trials, seed: int) -> Outcome:
    outcome, _ = simulate(
        sc, law, initial=trials.initial, geometries=trials.geometries, record=False, seed=seed
    )
    return outcome


def replay_trial(sc: Scenario, law: str, trials: Trials, index: int,
                 batch: int = BATCH) -> SimResult:  # fmt: skip
    """Trial ``index`` of a study again, with its full trajectory: its batch is simulated with
    the batch's noise seed (the noise of a lockstep batch is drawn for all its rows at once),
    and the trial's row kept. The result's scenario carries the trial's true part and deviation;
    its summary is the study's row for that trial."""
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(trials):
        raise ConfigError("trial", index, f"an index in [0, {len(trials) - 1}] of the study")
    j, row = divmod(index, batch)
    part = trials.part(slice(j * batch, min((j + 1) * batch, len(trials))))
    outcome, traj = simulate(sc, law, initial=part.initial, geometries=part.geometries,
                             record=True, seed=sc.seed + j)  # fmt: skip
    assert traj is not None  # record=True
    arrays = (getattr(traj, f.name) for f in dataclasses.fields(traj))
    one = Trajectory(*(a if a.ndim == 1 else a[:, row : row + 1] for a in arrays))
    true = dataclasses.replace(sc, geometry=part.geometries[row], initial=part.initial[row])
    summary = outcome.summary(row)
    summary["state_sequence"] = state_sequence(one, true.geometry)
    return SimResult(true, law, summary, one)


def concat(outcomes: Sequence[Outcome]) -> Outcome:
    """The outcomes of consecutive batches as one."""
    fields = [f.name for f in dataclasses.fields(Outcome)]
    return Outcome(**{f: np.concatenate([getattr(o, f) for o in outcomes]) for f in fields})


def run_montecarlo(
    sc: Scenario,
    laws: Sequence[str],
    trials: Trials,
    *,
    workers: int | None = 2,
    batch: int = BATCH,
    progress: Callable[[int, int], None] | None = None,
    scheduler: str | None = None,
) -> dict[str, Outcome]:
    """Run every law on the same trials; returns the outcomes per law, in trial order.

    Args:
        sc: Scenario with the nominal geometry, gains, sensor, robot and timing.
        laws: Names of the laws to run.
        trials: From :func:`draw_trials`.
        workers: Local processes (None: every core); 1 runs in this process (no pool).
        batch: Trials per task (the lockstep batch size).
        progress: Called with (tasks done, tasks total) as tasks finish.
        scheduler: Address of a running Dask scheduler to run the tasks on instead
            (:func:`fbcc_ros.core.sim.parallel.run_tasks`); the results are the same.
    """
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ConfigError("workers", workers, "an integer >= 1")
    parts = [slice(i, min(i + batch, len(trials))) for i in range(0, len(trials), batch)]
    # one noise seed per batch, derived from the scenario's seed: reproducible at any worker count
    tasks = [(law, j, part) for law in laws for j, part in enumerate(parts)]
    outcomes = run_tasks(
        _run_part,
        [(sc, law, trials.part(part), sc.seed + j) for law, j, part in tasks],
        workers=workers, scheduler=scheduler, progress=progress,
    )  # fmt: skip
    results = {(law, j): o for (law, j, _), o in zip(tasks, outcomes, strict=True)}
    return {law: concat([results[law, j] for j in range(len(parts))]) for law in laws}
