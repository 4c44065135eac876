"""Campaigns run classical IBVS in batches: each row is the row of the run alone, the keys unchanged.

``run_specs`` runs the specs of one batch key (method, plant, camera, settings, duration,
disturbances) in one ``simulate_batch`` call and the others alone; its rows are compared with
``run_spec``'s, every column but the measured times, on seeded free-planar cases (monocular
normalized camera, the depths from SQPnP) and arm-physical cases on the kinematic arm (stereo).
They are equal to the bit. Against the plug-in loop (what ``run_spec`` gave before classical IBVS,
PBVS, the hybrid law and polar IBVS had compiled paths; the rows of the last three, run alone,
included),
every number to 1e-9, relative or absolute (SQPnP's stopping tolerance is the difference, measured
6e-10 relative on ``final_position_mm``).
"""

from __future__ import annotations

import contextlib
import json
import math

import numpy as np
import pytest

from ibvs_youla.campaign.arms import arm_from_record
from ibvs_youla.campaign.cases import generate_cases
from ibvs_youla.campaign.definition import CampaignDefinition
from ibvs_youla.campaign.metrics import row_from_result
from ibvs_youla.campaign.run import batch_key, run_spec, run_specs
from ibvs_youla.campaign.runner import tasks_of
from ibvs_youla.campaign.spec import specs_for
from ibvs_youla.simulation.simulate import simulate

TIMED = ("wall_s", "update_median_us", "update_p95_us")
FREE = dict(
    plant="free-camera",
    camera={"kind": "normalized"},
    duration=8.0,
    settings={"joint_rate_hz": 25.0, "camera_rate_hz": 25.0},
)


def same_row(a, b, tolerance=0.0):
    assert a.keys() == b.keys()
    for column, value in a.items():
        if column in TIMED:
            continue
        other = b[column]
        if isinstance(value, float) and math.isfinite(value):
            assert abs(value - other) <= tolerance * max(1.0, abs(other)), (column, value, other)
        elif isinstance(value, float):  # NaN or infinite: the same
            assert str(value) == str(other), (column, value, other)
        else:
            assert value == other, (column, value, other)


@pytest.fixture(scope="module")
def free_specs():
    methods = ("ibvs-current", "pbvs", "ibvs-desired", "ibvs-mean")
    return specs_for(generate_cases("free-planar", 5, 0), methods, seed=0, **FREE)


def test_batched_rows_are_the_rows_of_runs_alone_and_of_the_plug_in_loop(free_specs):
    batched = run_specs([s.to_json() for s in free_specs])
    assert [r["key"] for r in batched] == [s.key for s in free_specs]  # in order, keys unchanged
    for spec, row in zip(free_specs, batched, strict=True):
        same_row(row, run_spec(spec))
        result = simulate(**spec.build(), loop="plug-in")  # the row before the compiled paths
        assert result.metadata["loop"] == "plug-in"
        same_row(row, row_from_result(spec, result), tolerance=1e-9)


@pytest.mark.parametrize("method", ["hybrid", "ibvs-polar"])
def test_the_hybrid_and_polar_laws_rows_are_the_plug_in_loops(method):
    """The hybrid law and polar IBVS run alone, on their compiled frame paths: their rows are the plug-in
    loop's (what ``run_spec`` gave before those paths) to 1e-9. None of the hybrid law's five switches
    (the switching runs are ``tests/test_compiled_hybrid.py``'s)."""
    specs = specs_for(generate_cases("free-planar", 5, 0), (method,), seed=0, **FREE)
    for spec in specs:
        compiled = simulate(**spec.build())
        plugged = simulate(**spec.build(), loop="plug-in")
        assert compiled.metadata["loop"] == "compiled" and plugged.metadata["loop"] == "plug-in"
        if method == "hybrid":
            assert compiled.hybrid_switches[-1, 0] == plugged.hybrid_switches[-1, 0] == 0.0  # as said above
        same_row(run_spec(spec), row_from_result(spec, plugged), tolerance=1e-9)


def test_the_kinematic_arm_with_the_stereo_camera():
    specs = specs_for(
        generate_cases("arm-physical", 2, 0), ("ibvs-mean",), seed=0, plant="kinematic",
        camera={"kind": "stereo"}, duration=2.0, settings={"joint_rate_hz": 100.0, "camera_rate_hz": 25.0},
    )  # fmt: skip
    batched = run_specs(specs)
    for spec, row in zip(specs, batched, strict=True):
        same_row(row, run_spec(spec))
        assert np.isfinite(row["final_jacobian_sigma"]) and row["final_jacobian_sigma"] > 0.0
    assert arm_from_record(None) is arm_from_record(None)  # one arm per record, process and thread


@pytest.mark.parametrize("family", ["arm-physical", "arm-eye-to-hand"])
def test_a_batch_runs_on_the_spec_s_arm_and_mount(family, monkeypatch):
    """The batch takes each spec's arm (not the IRB 4600); every row is the one run_spec gives (whose
    eye-to-hand J is J_rel's: tests/test_eye_to_hand_campaign.py)."""
    from ibvs_youla.campaign import run as run_module
    from ibvs_youla.model.arm import Arm

    definition = CampaignDefinition(
        family, 2, ("ibvs-current",), plant="kinematic", arm=Arm.from_robot("ur5"), duration=2.0
    )
    specs = definition.specs()
    on_irb = CampaignDefinition(family, 2, ("ibvs-current",), plant="kinematic", duration=2.0).specs()
    assert batch_key(specs[0]) == batch_key(specs[1]) != batch_key(on_irb[0])  # the arm is in the key
    with monkeypatch.context() as patched:  # every row from the batch: none of them run alone
        patched.setattr(run_module, "run_spec_with_result", lambda spec: pytest.fail("ran alone"))
        batched = run_specs(specs)
    for spec, row in zip(specs, batched, strict=True):
        same_row(row, run_spec(spec))
        assert row["status"] == "complete"


def test_tasks_group_the_runs_of_one_batch_key_in_the_campaigns_order(free_specs):
    keys = [batch_key(s) for s in free_specs]
    assert [k is None for k in keys[:4]] == [False, True, False, False]  # pbvs runs alone
    assert len({k for k in keys if k is not None}) == 3  # one per classical method
    tasks = tasks_of(free_specs, size=3)
    assert [len(t) for t in tasks] == [3, 1, 3, 3, 1, 1, 2, 1, 2, 2, 1]  # each task where its first run is
    assert [s.controller for s in tasks[0]] == ["ibvs-current"] * 3 and tasks[1][0].controller == "pbvs"
    assert sorted(s.key for t in tasks for s in t) == sorted(s.key for s in free_specs)
    dynamic = specs_for(generate_cases("arm-physical", 1, 0), ("ibvs-current",), seed=0, plant="dynamic",
                        camera={"kind": "stereo"}, duration=1.0)  # fmt: skip
    assert batch_key(dynamic[0]) is None  # simulate_batch does not run the dynamic arm


def test_a_batch_it_refuses_runs_its_specs_alone():
    """Pixel noise wraps the sensor: the batch refuses, each spec runs alone, with the same rows."""
    specs = specs_for(
        generate_cases("free-planar", 2, 1),
        ("ibvs-desired",),
        seed=1,
        disturbances={"pixel_noise_px": 0.5},
        **FREE,
    )
    for spec, row in zip(specs, run_specs(specs), strict=True):
        same_row(row, run_spec(spec))


class _Future:
    def __init__(self, key, value=None, killed=False):
        self.key, self.value = key, value
        self.status = "error" if killed else "finished"

    def result(self):
        return self.value

    def exception(self):
        from types import SimpleNamespace

        from distributed.scheduler import KilledWorker

        return KilledWorker(self.key, SimpleNamespace(address="tcp://127.0.0.1:1"), 2)

    def release(self):
        pass


class _ClusterKillingBatches:
    """A Dask client stand-in whose batch tasks all kill their worker (KilledWorker); single runs finish."""

    def __init__(self):
        self.submissions = []

    def map(self, function, items, pure, retries):
        futures = []
        for item in items:
            if isinstance(item, list):  # a batch task: its runs' JSON
                self.submissions.append(sorted(json.loads(s)["case"] for s in item))
                futures.append(_Future(f"batch-{len(self.submissions)}", killed=True))
            else:
                self.submissions.append([json.loads(item)["case"]])
                futures.append(_Future(f"run-{len(self.submissions)}", function(item)))
        return futures

    def nthreads(self):
        return {"tcp://127.0.0.1:1": 1}

    status = "running"  # a Dask client's, until it gives its scheduler up

    def as_current(self):  # the loop waits on this client, not the process's default one
        return contextlib.nullcontext()


def test_a_batch_that_kills_its_worker_runs_again_run_by_run(tmp_path, monkeypatch):
    import threading

    import distributed

    from ibvs_youla.campaign import runner, storage
    from ibvs_youla.campaign.definition import CampaignDefinition

    monkeypatch.setattr(distributed, "wait", lambda futures, timeout, return_when: (set(futures), set()))
    definition = CampaignDefinition("free-planar", 3, ("ibvs-desired",), seed=3, duration=2.0)
    storage.create_folder(tmp_path, definition.to_dict())
    writer = storage.RowWriter(tmp_path, 100, 1e9)
    summary = runner.CampaignSummary(tmp_path, 3, 0)
    client = _ClusterKillingBatches()
    bar = runner._progress_bar(3, 0, False)
    runner._collect(client, definition.specs(), writer, summary, bar, tmp_path, False, threading.Event())
    writer.flush()
    assert client.submissions == [[0, 1, 2], [0], [1], [2]]  # together, then each alone after the others
    rows = storage.read_rows(tmp_path).sort_values("case")
    assert summary.errors == 0 and list(rows["case"]) == [0, 1, 2]
    for spec in definition.specs():
        same_row(rows.set_index("key").loc[spec.key].to_dict() | {"key": spec.key}, run_spec(spec))


def test_a_spec_that_does_not_read_gets_its_row_and_the_batch_runs_the_others(free_specs):
    specs = [s.to_json() for s in free_specs if s.controller == "ibvs-desired"][:3]
    rows = run_specs([specs[0], "{not json", specs[1], specs[2]])
    assert rows[1]["outcome"] == "error" and "{not json" in rows[1]["spec"]
    for json_spec, row in zip([specs[0], specs[1], specs[2]], [rows[0], rows[2], rows[3]], strict=True):
        same_row(row, run_spec(json_spec))
