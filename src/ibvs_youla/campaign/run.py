"""Run one :class:`~.spec.ExperimentSpec` and return its row, whatever happens.

:func:`run_spec` is what a campaign sends to its workers: it builds the scenario, controller,
camera and settings from the spec, simulates, and returns :func:`~.metrics.row_from_result`.
A run that raises (a bad spec, a diverging plant, a controller refusing its task) is not an
exception for the campaign: its row has the outcome ``"error"`` (or ``"diverged"``, measured
on the partial record) and the message; so has a spec that does not read (malformed JSON, or
not a spec: :func:`~.metrics.unreadable_spec_row`). The arm is the spec's (its record, ``spec.arm``;
none: the IRB 4600), rebuilt by :func:`~.arms.arm_from_record` once per record, process and
thread (its Pinocchio data is per thread already; building it costs 50-300 ms); a record whose
robot description cannot be loaded is an ``"error"`` row.
"""

from __future__ import annotations

import time
from typing import Any

from ..exceptions import SimulationDivergedError
from .arms import arm_from_record
from .metrics import error_row, row_from_result, unreadable_spec_row
from .spec import ExperimentSpec

__all__ = ["run_spec", "run_spec_with_result"]


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
        return row_from_result(spec, err.partial, arm, time.perf_counter() - t0), err.partial
    except Exception as err:  # every failure becomes a row: the campaign goes on
        return error_row(spec, err, time.perf_counter() - t0), None
    if (
        arm is not None and kwargs["scenario"].is_eye_to_hand
    ):  # the row's J: the camera's relative to the markers
        from ..model.eye_to_hand import mounted

        arm = mounted(arm, kwargs["scenario"].mount)
    return row_from_result(spec, result, arm, time.perf_counter() - t0), result
