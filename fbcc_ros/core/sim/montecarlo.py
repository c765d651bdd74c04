"""Robustness at scale: many assemblies with random deviations, tolerances and materials.

Each trial draws

* the hole's unknown deviation: dx, dy uniform in ±max_offset, theta_x, theta_y uniform in
  ±max_tilt (defaults ±0.1 mm, ±2°, as the paper's experiment and Section IV.C);
* the true radii: each of R and r moves uniformly within ± half the range of the diameters
  measured in one group of Table II, the group drawn per trial (:func:`mapping_study.perturbed`);
* optionally the material: eq. 8's k log-uniform in ``stiffness`` = (low, high) [Pa] and mu
  uniform in ``friction`` = (low, high); by default both stay nominal;
* optionally the fit and the entry: the radial clearance R - r uniform in ``clearance`` =
  (low, high) [m] (the peg's radius follows the drawn hole's), and the 45° chamfer's width
  uniform in ``chamfer`` = (low, high) [m] (a pair with its rim, :attr:`PegHole.rim`). Each
  draw is taken after the others, so a study without it draws the same parts as before;
* optionally the grip: its lateral and angular stiffness log-uniform in ``grip`` = (lateral
  low, lateral high, angular low, angular high) [N/m, N·m/rad] (:class:`~fbcc_ros.core.sim.
  holder.Holder`, axial as shipped), in place of the scenario's holder; drawn after the others;
* optionally, on MuJoCo, the contact's stiffness: ``solref``'s time constant log-uniform in
  ``contact`` = (low, high) [s], in place of the scenario's ``plant.timeconst``, the impedance's
  width following it (:func:`~fbcc_ros.core.sim.plants.mujoco.impedance_width`): 0.2 ms is the
  shipped metal-like contact, 1 ms a plastic-like one; drawn last.

A part whose quasi-static push-in force (:meth:`PegHole.push_in_force` at L) exceeds
``feasible_force`` cannot be inserted by any controller within the force limit; when
``feasible_force`` is given such a part is drawn again (its deviations kept) and counted in
:attr:`Trials.redrawn`, so that the study measures the controller, not the impossible.

**A trial is its seed.** Trial i of a study with seed s draws from its own generator,
``SeedSequence([s, i])``, and its sensor noise from ``SeedSequence([scenario.seed, s, i])``
under a spawn key of its own (:data:`NOISE_KEY`), a stream apart from every draw's: its
outcome depends on (scenario, s, i) only, not on how many trials the study has, in which batch
or on which worker it ran, so ``--seed s --trial i`` replays it alone. Every law sees the same
trials. The trials are split in batches that run in lockstep (:func:`simulation.simulate`) on a
pool of local processes or on a Dask cluster (:mod:`fbcc_ros.core.sim.parallel`).
"""

from __future__ import annotations

import dataclasses
import math
import operator
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from fbcc_ros.core.arrays import FloatArray
from fbcc_ros.core.contact.mapping_study import perturbed
from fbcc_ros.core.contact.model import PegHole
from fbcc_ros.core.errors import ConfigError
from fbcc_ros.core.sim.holder import Holder
from fbcc_ros.core.sim.parallel import run_tasks
from fbcc_ros.core.sim.scenario import Scenario
from fbcc_ros.core.sim.simulation import Outcome, SimResult, simulate, state_sequence

DEFAULT_MAX_OFFSET = 1e-4  # [m]
DEFAULT_MAX_TILT = math.radians(2.0)  # [rad]
#: The spawn key of the noise streams (the draws' is empty).
NOISE_KEY = (1,)
#: Trials per lockstep batch (and per task of the pool), per plant: the model's batch is
#: vectorised; MuJoCo steps its trials in turn, so one trial per task keeps every core busy.
BATCH = {"model": 128, "mujoco": 1}


@dataclasses.dataclass(frozen=True)
class Trials:
    """The random part of N trials: deviations (N, 5), true geometries, the study's seed and
    each trial's number in the study, how many parts were drawn again because they could
    not be inserted (see the module doc), and each trial's grip and MuJoCo contact time
    constant [s] where they were drawn."""

    initial: FloatArray
    geometries: tuple[PegHole, ...]
    seed: int
    numbers: tuple[int, ...]
    redrawn: int = 0
    holders: tuple[Holder, ...] | None = None
    timeconsts: tuple[float, ...] | None = None

    def __len__(self) -> int:
        return len(self.initial)

    def part(self, s: slice) -> Trials:
        return Trials(self.initial[s], self.geometries[s], self.seed, self.numbers[s],
                      holders=None if self.holders is None else self.holders[s],
                      timeconsts=None if self.timeconsts is None else self.timeconsts[s])

    def scenario(self, sc: Scenario) -> Scenario:
        """``sc`` with this one trial's MuJoCo contact where it was drawn (``sc`` where not)."""
        if self.timeconsts is None:
            return sc
        if len(self) != 1:
            raise ConfigError("trials", len(self), "1: a drawn contact is a trial's own")
        return dataclasses.replace(sc, plant=dataclasses.replace(sc.plant,
                                                                 timeconst=self.timeconsts[0]))

    def noise_seeds(self, scenario_seed: int) -> list[np.random.SeedSequence]:
        """Each trial's noise seed (module doc), a stream apart from every draw's: its spawn
        key (NumPy pads a short entropy with zeros, so ``[a, s, 0]`` alone would be the draw
        stream ``[a, s]``)."""
        return [np.random.SeedSequence([scenario_seed, self.seed, i], spawn_key=NOISE_KEY)
                for i in self.numbers]  # fmt: skip


def draw_trials(
    nominal: PegHole,
    n: int,
    seed: int,
    max_offset: float = DEFAULT_MAX_OFFSET,
    max_tilt: float = DEFAULT_MAX_TILT,
    *,
    stiffness: tuple[float, float] | None = None,
    friction: tuple[float, float] | None = None,
    clearance: tuple[float, float] | None = None,
    chamfer: tuple[float, float] | None = None,
    grip: tuple[float, float, float, float] | None = None,
    contact: tuple[float, float] | None = None,
    feasible_force: float | None = None,
    numbers: Sequence[int] | None = None,
) -> Trials:
    """N random trials around the nominal pair, trials 0 to N-1 of the study ``seed`` (see the
    module doc).

    Args:
        numbers: Draw these trials of the study instead (each the same as in any study of that
            seed that has it); N is then ignored.
        stiffness: (low, high) of a log-uniform k [Pa]; None keeps the nominal k.
        friction: (low, high) of a uniform mu; None keeps the nominal mu.
        clearance: (low, high) of a uniform radial clearance [m]; None keeps the drawn radii.
        chamfer: (low, high) of a uniform chamfer width [m]; None keeps the nominal's.
        grip: (lateral low, lateral high, angular low, angular high) of a log-uniform grip
            [N/m, N·m/rad]; None keeps the scenario's holder.
        contact: (low, high) of a log-uniform MuJoCo contact time constant [s]; None keeps
            the scenario's ``plant.timeconst``.
        feasible_force: Largest quasi-static push-in force at L [N] of a part kept; None keeps
            every part.
    """
    if numbers is None:
        if not (isinstance(n, int) and n >= 1):
            raise ConfigError("trials", n, "an integer >= 1")
        numbers = range(n)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError("seed", seed, "an integer >= 0")
    numbers = [_trial_number(i) for i in numbers]
    if not numbers or len(set(numbers)) != len(numbers):
        raise ConfigError("trials", numbers[:10], "one or more distinct trial numbers")
    if chamfer is not None and not nominal.rim:
        raise ConfigError("chamfer", list(chamfer), "a pair with its rim (geometry.rim: true)")
    for name, bounds, zero in (("stiffness", stiffness, False), ("friction", friction, False),
                               ("clearance", clearance, False), ("chamfer", chamfer, True),
                               ("contact", contact, False)):
        if bounds is not None and not ((bounds[0] >= 0 if zero else bounds[0] > 0)
                                       and bounds[0] <= bounds[1]):
            allowed = "0 <= low <= high" if zero else "0 < low <= high"
            raise ConfigError(name, list(bounds), f"(low, high) with {allowed}")
    if grip is not None and not (0 < grip[0] <= grip[1] and 0 < grip[2] <= grip[3]):
        raise ConfigError("grip", list(grip), "(lateral low, high, angular low, high), each "
                          "0 < low <= high")  # fmt: skip
    initial = np.zeros((len(numbers), 5))
    geometries: list[PegHole] = []
    holders: list[Holder] = []
    timeconsts: list[float] = []
    redrawn = 0
    for row, i in enumerate(numbers):
        rng = np.random.default_rng([seed, i])  # the trial's own draw (module doc)
        tries = 0
        initial[row, :2] = rng.uniform(-max_offset, max_offset, 2)
        initial[row, 3:] = rng.uniform(-max_tilt, max_tilt, 2)
        while True:
            g = perturbed(nominal, rng, friction_spread=0.0, stiffness_octaves=0.0)
            if stiffness is not None:
                k = 10.0 ** rng.uniform(math.log10(stiffness[0]), math.log10(stiffness[1]))
                g = g.replace(stiffness=float(k))
            if friction is not None:
                g = g.replace(friction=float(rng.uniform(*friction)))
            if clearance is not None:
                g = g.replace(peg_radius=g.hole_radius - float(rng.uniform(*clearance)))
            if chamfer is not None:
                g = g.replace(chamfer=float(rng.uniform(*chamfer)))
            if feasible_force is None or g.push_in_force() <= feasible_force:
                break
            redrawn, tries = redrawn + 1, tries + 1
            if tries > 100:  # per trial: a trial drawn alone is refused only as in its study
                raise ConfigError(
                    "feasible_force", feasible_force,
                    f"a force most drawn parts can be pushed in with (trial {i}: 100 draws "
                    "were all too tight: is the fit an interference too stiff to insert?)",
                )  # fmt: skip
        geometries.append(g)
        if grip is not None:
            lateral, angular = (10.0 ** rng.uniform(math.log10(lo), math.log10(hi))
                                for lo, hi in (grip[:2], grip[2:]))  # fmt: skip
            holders.append(Holder(float(lateral), float(angular)))
        if contact is not None:
            timeconsts.append(float(10.0 ** rng.uniform(*np.log10(contact))))
    return Trials(initial, tuple(geometries), seed, tuple(numbers), redrawn,
                  tuple(holders) if grip is not None else None,
                  tuple(timeconsts) if contact is not None else None)


def _trial_number(value: Any) -> int:
    try:
        number = operator.index(value)  # an int, a NumPy integer; not a float, not a bool
    except TypeError:
        number = -1
    if isinstance(value, bool) or number < 0:
        raise ConfigError("trial", value, "an integer >= 0")
    return number


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """95 % Wilson score interval of a success rate (honest at 0 % and 100 %, unlike Wald)."""
    if n <= 0:
        return math.nan, math.nan
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def _run_part(sc: Scenario, law: str, trials: Trials) -> Outcome:
    if trials.timeconsts is not None and len(trials) > 1:  # a MuJoCo scene per contact
        return concat([_run_part(sc, law, trials.part(slice(i, i + 1)))
                       for i in range(len(trials))])  # fmt: skip
    outcome, _ = simulate(trials.scenario(sc), law, initial=trials.initial,
                          geometries=trials.geometries,
                          record=False, noise_seeds=trials.noise_seeds(sc.seed),
                          holders=trials.holders)  # fmt: skip
    return outcome


def replay_trial(sc: Scenario, law: str, trials: Trials, number: int) -> SimResult:
    """Trial ``number`` of the study again, alone, with its full trajectory (a trial is its
    seed: the module doc). The result's scenario carries the trial's true part and deviation;
    its summary is the study's row for that trial."""
    if number not in trials.numbers:
        raise ConfigError("trial", number, f"a trial drawn: {list(trials.numbers)[:10]}...")
    row = trials.numbers.index(number)
    one = trials.part(slice(row, row + 1))
    sc = one.scenario(sc)
    outcome, traj = simulate(sc, law, initial=one.initial, geometries=one.geometries,
                             noise_seeds=one.noise_seeds(sc.seed),
                             holders=one.holders)  # fmt: skip
    assert traj is not None  # record=True
    true = dataclasses.replace(sc, geometry=one.geometries[0], initial=one.initial[0],
                               holder=sc.holder if one.holders is None else one.holders[0])
    summary = outcome.summary(0)
    summary["state_sequence"] = state_sequence(traj, true.geometry)
    return SimResult(true, law, summary, traj)


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
    batch: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    scheduler: str | None = None,
) -> dict[str, Outcome]:
    """Run every law on the same trials; returns the outcomes per law, in trial order.

    Args:
        sc: Scenario with the nominal geometry, gains, sensor, robot and timing.
        laws: Names of the laws to run.
        trials: From :func:`draw_trials`.
        workers: Local processes (None: every core); 1 runs in this process (no pool).
        batch: Trials per task (the lockstep batch size); default the plant's
            (:data:`BATCH`). The outcomes do not depend on it (module doc).
        progress: Called with (tasks done, tasks total) as tasks finish.
        scheduler: Address of a running Dask scheduler to run the tasks on instead
            (:func:`fbcc_ros.core.sim.parallel.run_tasks`); the results are the same.
    """
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise ConfigError("workers", workers, "an integer >= 1")
    size = batch or BATCH[sc.plant.type]
    parts = [slice(i, min(i + size, len(trials))) for i in range(0, len(trials), size)]
    tasks = [(law, j, part) for law in laws for j, part in enumerate(parts)]
    outcomes = run_tasks(
        _run_part,
        [(sc, law, trials.part(part)) for law, j, part in tasks],
        workers=workers, scheduler=scheduler, progress=progress,
    )  # fmt: skip
    results = {(law, j): o for (law, j, _), o in zip(tasks, outcomes, strict=True)}
    return {law: concat([results[law, j] for j in range(len(parts))]) for law in laws}
