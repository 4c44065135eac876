"""The run timeout's retries on a simulated cluster: which copy is stored, and when a row is a timeout.

``FakeCluster`` stands for a Dask client and scheduler in simulated time: workers of one thread
that hold at most two runs each (the scheduler's queuing, ``worker-saturation`` 1.1), run them
in priority then submission order, and take a given time per run; a stopped worker (SIGSTOP)
never finishes one. Unrestricted runs wait in the scheduler's queue for a free slot; runs
restricted to workers go to the least loaded of them at once. The campaign loop
(``runner._collect``) runs unchanged on it; ``time.monotonic`` and ``distributed.wait`` advance
the simulated clock.
"""

from __future__ import annotations

import contextlib
import itertools
import re
import threading
from types import SimpleNamespace

import distributed
import pytest

from ibvs_youla.campaign import runner
from ibvs_youla.campaign.definition import CampaignDefinition
from ibvs_youla.campaign.spec import ExperimentSpec

TIMEOUT_S = 10.0  # the campaign's run timeout in these tests [s]
SPECS = CampaignDefinition(family="free-planar", cases=4, controllers=("pbvs",), duration=1.0).specs()


class FakeFuture:
    def __init__(self, cluster, key, spec, priority, restricted):
        self.cluster, self.key, self.spec = cluster, key, spec
        self.priority, self.restricted = priority, restricted
        self.status, self.worker, self.started = "pending", None, None

    def result(self):
        return {"key": self.spec.key, "outcome": "reached", "copy": self.key}

    def exception(self):
        return None

    def release(self):
        self.cluster.release(self)


class FakeCluster:
    """Two-slot workers in simulated time (module docstring); ``durations``: worker -> seconds per run."""

    def __init__(self, durations, slow_first=None, hangs=()):
        self.durations = durations  # None: stopped
        self.slow_first = slow_first or {}  # worker -> duration of its first run [s]
        self.hangs = set(hangs)  # spec keys whose runs never return, on any worker
        self.now = 0.0
        self.held = {w: [] for w in durations}  # worker -> futures assigned, in order
        self.queue: list[FakeFuture] = []
        self.runs_done = {w: 0 for w in durations}
        self.counter = itertools.count()
        self.scheduler = SimpleNamespace(address="tcp://fake:1")
        self.released: list[str] = []
        self.futures: dict[str, FakeFuture] = {}

    # --- client API used by the campaign loop
    def nthreads(self):
        return dict.fromkeys(self.durations, 1)

    status = "running"  # a Dask client's, until it gives its scheduler up

    def as_current(self):  # the loop waits on this client, not the process's default one
        return contextlib.nullcontext()

    def processing(self):
        return {w: [f.key for f in futures] for w, futures in self.held.items()}

    def map(self, function, texts, pure, retries, priority=0, workers=None, allow_other_workers=None):
        futures = []
        for text in texts:
            spec = ExperimentSpec.from_json(text)
            future = FakeFuture(self, f"run-{next(self.counter)}", spec, priority, workers)
            futures.append(future)
            self.futures[future.key] = future
            if workers:
                target = min(workers, key=lambda w: len(self.held[w]))
                self._assign(future, target)
            else:
                self.queue.append(future)
        self._dispatch()
        return futures

    # --- simulation
    def _assign(self, future, worker):
        future.worker = worker
        self.held[worker].append(future)
        self._start(worker)

    def _dispatch(self):
        self.queue.sort(key=lambda f: (-f.priority, int(f.key.split("-")[1])))
        for worker in self.held:
            while self.queue and len(self.held[worker]) < 2:
                self._assign(self.queue.pop(0), worker)

    def _start(self, worker):
        futures = self.held[worker]
        if futures and not any(f.started is not None for f in futures):
            nxt = min(futures, key=lambda f: (-f.priority, int(f.key.split("-")[1])))
            nxt.started = self.now

    def _duration(self, future):
        worker = future.worker
        if self.durations[worker] is None or future.spec.key in self.hangs:
            return None
        return (
            self.slow_first.get(worker, self.durations[worker])
            if self.runs_done[worker] == 0
            else (self.durations[worker])
        )

    def release(self, future):
        self.released.append(future.key)
        if future in self.queue:
            self.queue.remove(future)
        if future.worker is not None and future in self.held[future.worker]:
            self.held[future.worker].remove(future)
            self._start(future.worker)
            self._dispatch()

    def advance(self, futures, timeout):
        """distributed.wait: simulated time runs to the first completion among ``futures``, or ``timeout``."""
        end = self.now + timeout
        assert end < 100 * TIMEOUT_S * len(SPECS), "the campaign does not end"
        while True:
            ends = [
                (f.started + d, f)
                for w, held in self.held.items()
                for f in held
                if f.started is not None and (d := self._duration(f)) is not None
            ]
            if not ends or min(ends, key=lambda e: e[0])[0] > end:
                self.now = end
                break
            t, future = min(ends, key=lambda e: e[0])
            self.now = t
            future.status = "finished"
            self.held[future.worker].remove(future)
            self.runs_done[future.worker] += 1
            self._start(future.worker)
            self._dispatch()
            if future in futures:
                break
        done = {f for f in futures if f.status == "finished"}
        return done, set(futures) - done


class FakeWriter:
    def __init__(self):
        self.rows, self.written = [], 0

    def add(self, row):
        self.rows.append(row)
        self.written += 1

    def __len__(self):
        return 0

    def seconds_until_due(self):
        return None

    def flush(self):
        return None


def _campaign(monkeypatch, cluster):
    """Run the campaign loop on ``cluster``; return (rows, warnings logged)."""
    monkeypatch.setattr(runner.time, "monotonic", lambda: cluster.now)
    monkeypatch.setattr(
        distributed, "wait", lambda futures, timeout, return_when: cluster.advance(list(futures), timeout)
    )
    warnings: list[str] = []
    monkeypatch.setattr(runner._LOG, "warning", lambda fmt, *args: warnings.append(fmt % args))
    writer, bar = FakeWriter(), SimpleNamespace(update=lambda n: None, set_postfix=lambda **k: None)
    bar.set_description = lambda *a, **k: None
    summary = runner.CampaignSummary(out_dir=None, runs=len(SPECS), stored_before=0)
    runner._collect(cluster, SPECS, writer, summary, bar, None, False, threading.Event(), TIMEOUT_S)
    return writer.rows, warnings


def test_a_stopped_workers_runs_finish_on_the_other(monkeypatch):
    cluster = FakeCluster({"A": None, "B": 1.0})  # A is stopped from the start, holding two runs
    rows, warnings = _campaign(monkeypatch, cluster)
    assert sorted(r["key"] for r in rows) == sorted(s.key for s in SPECS)  # every run once
    assert {r["outcome"] for r in rows} == {"reached"}
    assert warnings == [
        f"ibvs-youla: run {SPECS[0].key} took more than 10 s on A; running it again on another worker"
    ]
    assert {"run-0", "run-1"} <= set(cluster.released)  # A's originals: held until the end, then released


def test_the_first_copy_back_is_stored_and_a_late_one_dropped(monkeypatch):
    """A thaws at 18 s: its first run returns after that run's copy on B was stored: dropped."""
    cluster = FakeCluster({"A": 5.0, "B": 5.0}, slow_first={"A": 18.0})
    rows, _ = _campaign(monkeypatch, cluster)
    assert sorted(r["key"] for r in rows) == sorted(s.key for s in SPECS)  # once each: late copies dropped
    stored = {r["key"]: r["copy"] for r in rows}[SPECS[0].key]
    assert stored != "run-0" and cluster.futures[stored].spec.key == SPECS[0].key  # its copy, on B
    assert cluster.futures["run-0"].status == "finished" and cluster.now >= 18.0  # returned late: dropped


def test_a_run_that_hangs_every_worker_it_meets_is_a_timeout_row_naming_them(monkeypatch):
    """A run stuck in a solver hangs A, then its copy hangs B: stored as a timeout; C runs the rest."""
    cluster = FakeCluster({"A": 1.0, "B": 1.0, "C": 1.0}, hangs={SPECS[0].key})
    rows, _ = _campaign(monkeypatch, cluster)
    assert sorted(r["key"] for r in rows) == sorted(s.key for s in SPECS)
    (timeout,) = [r for r in rows if r["outcome"] == "timeout"]
    assert timeout["key"] == SPECS[0].key and {r["outcome"] for r in rows if r is not timeout} == {"reached"}
    assert re.fullmatch(r"timed out: no result after 1\d s on A then B", timeout["error"]), timeout["error"]


def test_a_campaign_whose_every_worker_hangs_stops_with_one_line_after_a_timeout_more(monkeypatch):
    cluster = FakeCluster({"A": None, "B": None})  # both stopped: nothing ever returns
    with pytest.raises(
        runner.SchedulerError, match="every worker has a run past the 10 s run timeout"
    ) as info:
        _campaign(monkeypatch, cluster)
    assert "(A, B) and none returned for 1" in str(info.value) and "the 0 rows returned" in str(info.value)
    assert 2 * TIMEOUT_S < cluster.now < 3 * TIMEOUT_S + 5.0  # stopped once hung a timeout more


def test_a_worker_slow_once_is_healthy_again_and_retries_finish_there(monkeypatch):
    """A is stopped; B's first run (its start-up) takes 15 s, past the timeout: both look hung at
    10 s. When B's run returns, B works again, and A's runs finish on it: no timeout rows."""
    cluster = FakeCluster({"A": None, "B": 1.0}, slow_first={"B": 15.0})
    rows, warnings = _campaign(monkeypatch, cluster)
    assert sorted(r["key"] for r in rows) == sorted(s.key for s in SPECS)
    assert {r["outcome"] for r in rows} == {"reached"}, [r.get("error") for r in rows]
    assert any("on B" in w for w in warnings)  # B's slow run was timed out too, and forgiven
