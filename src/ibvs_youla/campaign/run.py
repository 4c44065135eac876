"""Run one :class:`~.spec.ExperimentSpec`, or a batch of them, and return their rows, whatever happens.

:func:`run_spec` is what a campaign sends to its workers: it builds the scenario, controller,
camera and settings from the spec, simulates, and returns :func:`~.metrics.row_from_result`.
A run that raises (a bad spec, a diverging plant, a controller refusing its task) is not an
exception for the campaign: its row has the outcome ``"error"`` (or ``"diverged"``, measured
on the partial record) and the message; so has a spec that does not read (malformed JSON, or
not a spec: :func:`~.metrics.unreadable_spec_row`). The arm is the spec's (its record, ``spec.arm``;
none: the IRB 4600), rebuilt by :func:`~.arms.arm_from_record` once per record, process and
thread (its Pinocchio data is per thread already; building it costs 50-300 ms); a record whose
robot description cannot be loaded is an ``"error"`` row.

:func:`run_specs` runs several specs that differ only in their case (:func:`batch_key`: one method,
plant, camera, settings, arm and duration, any disturbances but their seed) in one
:func:`~ibvs_youla.simulate_batch` call, which gives each case the result ``simulate()`` gives it, so
each row is the one :func:`run_spec` returns (but for the measured times: a row's ``wall_s`` is its
share of the batch). What the batch does not give as ``run_spec`` does is run by ``run_spec``: a spec
of another key or one that does not read, a case that ended with an error (its row carries the
error's type and message), a batch that raises (each of its specs then runs alone, and a bad one
gets its own error row).
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from typing import Any

from ..exceptions import SimulationDivergedError
from .arms import arm_from_record
from .metrics import error_row, row_from_result, unreadable_spec_row
from .spec import ExperimentSpec

__all__ = ["batch_key", "run_spec", "run_spec_with_result", "run_specs", "run_specs_with_results"]


def run_spec(spec: ExperimentSpec | str) -> dict[str, Any]:
    """The row of one run (module docstring), whatever happens; ``spec`` may be its JSON."""
    return run_spec_with_result(spec)[0]


def run_spec_with_result(spec: ExperimentSpec | str) -> tuple[dict[str, Any], Any]:
    """The row of one run and its :class:`~ibvs_youla.simulation.results.SimulationResult`.

    The result is the partial record of a diverged run, and None when the run raised before
    recording anything. A campaign asks for it only to store full time series (``--series``).
    """
    from ..simulation.simulate import simulate

    t0 = time.perf_counter()
    if not isinstance(spec, ExperimentSpec):
        try:
            spec = ExperimentSpec.from_json(spec)
        except Exception as err:  # a row all the same: what was received, and why it is no spec
            return unreadable_spec_row(spec, err, time.perf_counter() - t0), None
    arm = None
    try:
        arm = None if spec.plant == "free-camera" else arm_from_record(spec.arm or None)
        kwargs = spec.build()
        result = simulate(**kwargs, arm=arm)
    except SimulationDivergedError as err:
        if err.partial is None:
            return error_row(spec, err, time.perf_counter() - t0), None
        row_arm = _row_arm(arm, kwargs["scenario"])
        return row_from_result(spec, err.partial, row_arm, time.perf_counter() - t0), err.partial
    except Exception as err:  # every failure becomes a row: the campaign goes on
        return error_row(spec, err, time.perf_counter() - t0), None
    return row_from_result(spec, result, _row_arm(arm, kwargs["scenario"]), time.perf_counter() - t0), result


def batch_key(spec: ExperimentSpec) -> str | None:
    """The key of the specs one ``simulate_batch`` call runs together, or None for a spec run alone.

    Specs of a registered classical IBVS method on a plant the batch covers (``BATCH_CONTROLLERS``,
    ``BATCH_PLANTS``) with the same method, parameters, plant, camera, settings, arm, duration and
    disturbances (their seed is the case's own) share a key. Whether their disturbances are ones the
    batch covers is for the batch to say (:func:`run_specs` then runs them alone).
    """
    from ..simulation.batch import BATCH_CONTROLLERS, BATCH_PLANTS

    if spec.controller not in BATCH_CONTROLLERS or spec.plant not in BATCH_PLANTS:
        return None
    data = spec.to_dict()
    shared = {
        k: data.get(k) for k in ("controller", "controller_params", "plant", "camera", "settings", "arm")
    }
    shared.update(duration=spec.duration, disturbances=data.get("disturbances", {}))
    return json.dumps(shared, sort_keys=True, separators=(",", ":"))


def run_specs(specs: Sequence[ExperimentSpec | str]) -> list[dict[str, Any]]:
    """The rows of several runs, in order (module docstring); each spec may be its JSON."""
    return [row for row, _ in run_specs_with_results(specs)]


def run_specs_with_results(specs: Sequence[ExperimentSpec | str]) -> list[tuple[dict[str, Any], Any]]:
    """The row and result of each run, in order, as :func:`run_spec_with_result` gives them.

    Runs of one :func:`batch_key` in one ``simulate_batch`` call (module docstring), the others alone.
    """
    parsed = [_parsed(s) for s in specs]
    out: list[tuple[dict[str, Any], Any] | None] = [None] * len(parsed)
    groups: dict[str, list[int]] = {}
    for i, spec in enumerate(parsed):
        key = batch_key(spec) if isinstance(spec, ExperimentSpec) else None  # unreadable: its own row
        if key is None:
            out[i] = run_spec_with_result(spec)
        else:
            groups.setdefault(key, []).append(i)
    for indices in groups.values():
        for i, pair in zip(indices, _batch([parsed[i] for i in indices]), strict=True):
            out[i] = pair if pair is not None else run_spec_with_result(parsed[i])
    return out  # type: ignore[return-value]


_OWN_STATUSES = ("complete", "markers_lost", "estimate_failed")  # what the batch's loop itself gives


def _batch(specs: list[ExperimentSpec]) -> list[tuple[dict[str, Any], Any] | None]:
    """Rows and results of specs of one batch key from one simulate_batch call (None: run it alone)."""
    from ..simulation.batch import simulate_batch

    t0 = time.perf_counter()
    try:
        built = [spec.build() for spec in specs]
        first = built[0]
        kwargs = {k: v for k, v in first.items() if k not in ("scenario", "disturbances")}
        disturbances = [b.get("disturbances") for b in built]
        arm = None if specs[0].plant == "free-camera" else arm_from_record(specs[0].arm or None)
        batch = simulate_batch([b["scenario"] for b in built], disturbances=disturbances, arm=arm, **kwargs)
    except Exception:  # a spec the batch refuses (or a bug): each runs alone, a bad one gets its error row
        return [None] * len(specs)
    share = (time.perf_counter() - t0) / len(specs)
    return [
        (row_from_result(spec, result, _row_arm(arm, b["scenario"]), share), result)
        if result.status in _OWN_STATUSES
        else None
        for spec, b, result in zip(specs, built, batch, strict=True)
    ]


def _parsed(spec: Any) -> Any:
    """The spec of ``spec`` (an ExperimentSpec or its JSON); as given if it does not read (run alone)."""
    if not isinstance(spec, str):
        return spec
    try:
        return ExperimentSpec.from_json(spec)
    except Exception:  # run_spec_with_result makes its row (metrics.unreadable_spec_row)
        return spec


def _row_arm(arm: Any, scenario: Any) -> Any:
    """The arm whose camera Jacobian a row reports: eye-to-hand, the camera's relative to the markers."""
    if arm is None or not scenario.is_eye_to_hand:
        return arm
    from ..model.eye_to_hand import mounted

    return mounted(arm, scenario.mount)
