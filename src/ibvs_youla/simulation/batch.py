"""``simulate_batch()``: many runs of classical IBVS at once, each equal to its ``simulate()``.

A study of many start poses (a basin of attraction, a campaign's cases) runs one law on one plant
from many scenarios. :func:`simulate_batch` prepares each case exactly as :func:`~.simulate.simulate`
does (:func:`~.simulate.prepare_run`: the same checks, roles, beliefs and metadata), then advances
all of them in lockstep, one compiled call per frame over the cases (:mod:`.batch_loop`), instead
of one Python loop per run. What it covers is what the compiled frame path covers for classical
IBVS (:mod:`.compiled_loop`; the compiled frame paths of PBVS, 2.5-D, the hybrid law and polar
IBVS run in ``simulate()`` only):

* the controller: ``"ibvs-current"``, ``"ibvs-desired"`` or ``"ibvs-mean"`` (a constant or adaptive
  gain), or a :class:`~ibvs_youla.controllers.ibvs.ClassicalIBVS` object;
* the plant: ``"free-camera"`` or ``"kinematic"`` (any arm; the dynamic arm runs in ``simulate()``);
* the sensor: the ideal one, with or without depth (``None``, ``"ideal"``, ``"depth"``); of the
  disturbances, the calibration errors (they change the controller's beliefs, not a role).

Each case's result is the one ``simulate()`` gives: the same kernels called in the same order on the
same numbers, so to the bit (``tests/test_simulate_batch.py`` checks every recorded number to 1e-9, on
every method x plant x camera covered, and on runs that stop early), with
``metadata["loop"] = "batch"``. A case that stops early in the plug-in loop stops at the same tick
with the same status and reason (a marker lost, an estimate failed); one whose kernel declines (a
non-finite command, a depth the law rejects) is run again alone by its plug-in loop, from the start,
and its result is that loop's (``metadata["loop"] = "plug-in"``; :attr:`BatchResult.rerun` lists
them). A run that raises in ``simulate()`` (a diverging plant, an invalid command) is not raised
here: its result is the error's ``partial`` record, with its status (``"diverged"``,
``"controller_failed"``), so that one case does not end the others.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from .._memory import fits_in_memory
from .._validation import flag
from ..controllers import Controller
from ..controllers.ibvs import ClassicalIBVS
from ..exceptions import ControllerError, IbvsYoulaError, InvalidParameterError, SimulationDivergedError
from ..model.arm import Arm
from ..model.camera import PinholeCamera, StereoCamera
from ..scenarios import Scenario
from .batch_loop import BatchLoop
from .compiled_loop import CompiledLoop
from .disturbances import Disturbances
from .recorder import ResultRecorder
from .results import SimulationResult
from .settings import SimulationSettings
from .simulate import Beliefs, PreparedRun, prepare_run

__all__ = ["BATCH_CONTROLLERS", "BATCH_PLANTS", "BATCH_SENSORS", "BatchResult", "simulate_batch"]

BATCH_CONTROLLERS = ("ibvs-current", "ibvs-desired", "ibvs-mean")
BATCH_PLANTS = ("free-camera", "kinematic")
BATCH_SENSORS = (None, "ideal", "depth")


@dataclass(frozen=True)
class BatchResult:
    """The runs of one :func:`simulate_batch` call, one per scenario, in the scenarios' order.

    Indexing, iteration and ``len`` go through :attr:`results`.

    Attributes:
        results: Each case's :class:`~.results.SimulationResult`, as ``simulate()`` gives it; for a
            run that ``simulate()`` ends with an error, the error's ``partial`` record (its status
            says which: ``"diverged"``, ``"controller_failed"``).
        rerun: Indices of the cases run again alone by their plug-in loop (module docstring).
        seconds: Wall time of the call's parts [s]: ``"setup"`` (every case prepared),
            ``"loop"`` (the lockstep loop), ``"rerun"`` (the plug-in reruns).
    """

    results: tuple[SimulationResult, ...]
    rerun: tuple[int, ...] = ()
    seconds: dict[str, float] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.results)

    def __getitem__(self, index: int) -> SimulationResult:
        return self.results[index]

    def __iter__(self) -> Iterator[SimulationResult]:
        return iter(self.results)

    @property
    def statuses(self) -> tuple[str, ...]:
        """Each case's status (``"complete"``, ``"markers_lost"``, ...)."""
        return tuple(r.status for r in self.results)


def simulate_batch(
    scenarios: Sequence[Scenario],
    controller: str | Controller,
    adaptive: bool = True,
    duration: float = 10.0,
    *,
    plant: str,
    camera: StereoCamera | PinholeCamera | None = None,
    settings: SimulationSettings | None = None,
    arm: Arm | None = None,
    beliefs: Beliefs | Sequence[Beliefs | None] | None = None,
    sensor: str | None = None,
    disturbances: Disturbances | Sequence[Disturbances | None] | None = None,
    progress: bool = False,
) -> BatchResult:
    """Simulate every scenario with one classical IBVS law on one plant, in lockstep (module docstring).

    Args:
        scenarios: The cases (a sequence of :class:`~ibvs_youla.scenarios.Scenario`, at least one),
            each with the same number of markers.
        controller: ``"ibvs-current"``, ``"ibvs-desired"``, ``"ibvs-mean"``, or a ``ClassicalIBVS``
            (e.g. ``iy.controllers.make("ibvs-current", gain=1.0)``), reset for each case.
        adaptive: As :func:`~.simulate.simulate` (True: the classical laws have no other variant).
        duration: Simulated time of every case [s].
        plant: ``"free-camera"`` or ``"kinematic"``.
        camera: The true camera of every case (default: :func:`~.simulate.simulate`'s).
        settings: Rates and recording of every case (``SimulationSettings``).
        arm: The true arm on the kinematic plant (default ``Arm.irb4600()``, built once).
        beliefs: Where the controller's models differ from the truth: one :class:`~.simulate.Beliefs`
            for every case, or one per scenario (None: the truth).
        sensor: ``None``, ``"ideal"`` or ``"depth"``, as :func:`~.simulate.simulate`.
        disturbances: Calibration errors (the other disturbances wrap a role this loop does not
            cover): one :class:`~.disturbances.Disturbances` for every case, or one per scenario
            (e.g. each seeded on its own).
        progress: Show a progress bar (tqdm) on stderr.

    Returns:
        One result per scenario (:class:`BatchResult`).

    Raises:
        InvalidParameterError: ``scenarios`` not a non-empty sequence of scenarios or with different
            marker counts; a plant, sensor or controller this loop does not cover (the message says
            to use ``simulate()``); disturbances that wrap a role; ``beliefs`` or ``disturbances``
            sequences of another length than ``scenarios``; a batch whose recordings would not fit
            in memory; and every error of :func:`~.simulate.simulate`'s checks, for the case that
            raised it (the error notes its index).
        IncompatibleCommandError, JointLimitError: as :func:`~.simulate.simulate`, for a case.
        KeyboardInterrupt: Ctrl-C, with ``error.partial`` a :class:`BatchResult` of what was recorded:
            every case (status ``"interrupted"`` where it had not ended) during the lockstep loop; the
            cases before and the one being run during a plug-in rerun; none while the cases are
            prepared.
    """
    t0 = time.perf_counter()
    if isinstance(scenarios, Scenario) or not isinstance(scenarios, Sequence) or not scenarios:
        got = "a Scenario" if isinstance(scenarios, Scenario) else type(scenarios).__name__
        if isinstance(scenarios, Sequence) and not scenarios:
            got = "an empty sequence"
        raise InvalidParameterError(
            "scenarios", got, "a non-empty sequence of Scenario (one run: simulate())"
        )
    for i, scenario in enumerate(scenarios):
        if not isinstance(scenario, Scenario):
            raise InvalidParameterError(f"scenarios[{i}]", type(scenario).__name__, "a Scenario")
    if plant not in BATCH_PLANTS:
        raise InvalidParameterError(
            "plant", plant, "'free-camera' or 'kinematic' (simulate() runs every plant, the dynamic arm too)"
        )
    if sensor not in BATCH_SENSORS:
        got = sensor if isinstance(sensor, str) else f"a {type(sensor).__name__}"
        raise InvalidParameterError(
            "sensor",
            got,
            "None, 'ideal' or 'depth' (the ideal sensor; simulate() runs rendered images and sensor "
            "functions)",
        )
    _check_controller(controller)
    progress = flag(progress, "progress")
    n = len(scenarios)
    per_beliefs = _per_case(beliefs, "beliefs", Beliefs, n)
    per_disturbances = _per_case(disturbances, "disturbances", Disturbances, n)
    if arm is None and (plant == "kinematic" or any(s.has_joints for s in scenarios)):
        arm = Arm.irb4600()  # once for the batch (each case would build its own)
    common = {"plant": plant, "camera": camera, "settings": settings, "arm": arm, "sensor": sensor}

    def prepare(i: int) -> PreparedRun:
        try:
            return prepare_run(
                scenarios[i],
                controller,
                adaptive,
                duration,
                beliefs=per_beliefs[i],
                disturbances=per_disturbances[i],
                **common,
            )
        except IbvsYoulaError as err:
            err.add_note(f"in simulate_batch's scenarios[{i}]")
            raise

    try:
        loops = [_covered(prepare(i), i, per_disturbances[i]) for i in range(n)]
        _check_sizes(loops)
    except KeyboardInterrupt as err:  # while the cases are prepared: nothing recorded yet
        err.partial = BatchResult(())  # type: ignore[attr-defined]
        raise
    first = loops[0]
    recorder = first.recorder
    n_rows = first.n_ticks // first.record_every + 2
    n_frames = first.n_ticks // first.ticks_per_frame + 1
    sizes = recorder.row_sizes[2:]
    shapes = {name: (int(size),) for name, size in zip(recorder.signal_names, sizes, strict=True)}
    per_case = ResultRecorder.estimate_bytes(
        n_rows, n_frames, first.law.shape[0], first.markers_O.shape[0], shapes
    )
    fits_in_memory(
        n * per_case,
        "scenarios",
        f"{n} scenarios",
        "fewer scenarios per call (several batches), a shorter duration or a larger settings.record_every",
    )
    t_loop = time.perf_counter()
    try:
        outcomes = BatchLoop(loops).run(progress)
    except KeyboardInterrupt as err:  # every case's record, as the single runs do
        # (a signal that lands before the loop's own handler, or in it, carries no record yet)
        err.partial = BatchResult(tuple(getattr(err, "partial", None) or ()))  # type: ignore[attr-defined]
        raise
    del loops
    t_rerun = time.perf_counter()
    results: list[SimulationResult] = []
    rerun: list[int] = []
    for i, result in enumerate(outcomes):
        if result is None:
            rerun.append(i)
            try:
                result = _plug_in(prepare(i))
            except KeyboardInterrupt as err:  # the cases before, and this one's record so far
                own = getattr(err, "partial", None)  # None: interrupted before its loop recorded
                err.partial = BatchResult(  # type: ignore[attr-defined]
                    (*results, *([] if own is None else [own])), tuple(rerun)
                )
                raise
        results.append(result)
    t_end = time.perf_counter()
    seconds = {"setup": t_loop - t0, "loop": t_rerun - t_loop, "rerun": t_end - t_rerun}
    return BatchResult(tuple(results), tuple(rerun), seconds)


def _check_controller(controller: Any) -> None:
    """A registered classical IBVS name or a ClassicalIBVS object; anything else: use simulate()."""
    valid = (
        "'ibvs-current', 'ibvs-desired' or 'ibvs-mean', or a ClassicalIBVS object (simulate() runs "
        "every other controller)"
    )
    if isinstance(controller, str):
        if controller not in BATCH_CONTROLLERS:
            raise InvalidParameterError("controller", controller, valid)
    elif type(controller) is not ClassicalIBVS:
        raise InvalidParameterError("controller", f"a {type(controller).__name__}", valid)


def _per_case(value: Any, name: str, kind: type, n: int) -> list[Any]:
    """One value per case: the same for all, or a sequence of one per scenario."""
    if value is None or isinstance(value, kind):
        return [value] * n
    if not isinstance(value, Sequence) or isinstance(value, str):
        raise InvalidParameterError(
            name, type(value).__name__, f"a {kind.__name__}, None, or a sequence of one per scenario"
        )
    if len(value) != n:
        raise InvalidParameterError(name, f"a sequence of {len(value)}", f"one per scenario ({n})")
    for i, item in enumerate(value):
        if item is not None and not isinstance(item, kind):
            raise InvalidParameterError(f"{name}[{i}]", type(item).__name__, f"a {kind.__name__} or None")
    return list(value)


def _covered(prepared: PreparedRun, i: int, disturbances: Disturbances | None) -> CompiledLoop:
    """The case's compiled loop; a role it does not cover can only be a disturbance's wrapper here."""
    loop = CompiledLoop.covering(*prepared.roles, prepared.recorder)
    if loop is None:
        given = disturbances.to_dict() if disturbances is not None else {}
        raise InvalidParameterError(
            f"disturbances of scenarios[{i}]",
            given,
            "calibration errors only: noise, dropouts, rendered images, latency, delays and limits wrap "
            "a role that simulate_batch does not cover (simulate() runs them)",
        )
    return loop


def _check_sizes(loops: list[CompiledLoop]) -> None:
    """Every case has the first one's markers, features and joints (one batch, one size)."""
    first = loops[0]
    shape = (first.markers_O.shape, first.law.shape, first.recorder.row_sizes.tolist())
    for i, loop in enumerate(loops[1:], start=1):
        if (loop.markers_O.shape, loop.law.shape, loop.recorder.row_sizes.tolist()) != shape:
            raise InvalidParameterError(
                "scenarios",
                f"scenarios[{i}] with {loop.markers_O.shape[0]} markers and {loop.law.shape[0]} features",
                f"scenarios of one size: {first.markers_O.shape[0]} markers and {first.law.shape[0]} "
                "features, as scenarios[0] (run the others in another batch)",
            )


def _plug_in(prepared: PreparedRun) -> SimulationResult:
    """The case run alone by its plug-in loop; a run that raises gives its partial record."""
    try:
        return prepared.run("plug-in")
    except (SimulationDivergedError, ControllerError) as err:
        if err.partial is None:
            raise
        return err.partial  # type: ignore[no-any-return]
