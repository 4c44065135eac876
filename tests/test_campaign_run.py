"""Campaign runs: stored once per (case, method), resumed, the same rows on a real Dask cluster.

The campaign of these tests: 12 free-planar cases (seed 3) x ibvs-current, pbvs, ibvs-desired,
20 s at 25 Hz on the free camera (36 runs, ~0.05 s each). Its rows from this process
(``workers=0``) are the reference that a real scheduler with two workers (one killed with
SIGKILL mid-run) and an interrupted-then-resumed client must reproduce: every column equal,
floats to 1e-12, except the measured times (wall_s, update_median_us, update_p95_us).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from distributed import Client

from ibvs_youla import cli, controllers
from ibvs_youla.campaign import runner
from ibvs_youla.campaign.definition import CampaignDefinition
from ibvs_youla.campaign.metrics import COLUMNS
from ibvs_youla.campaign.runner import run_campaign
from ibvs_youla.campaign.storage import RowWriter, create_folder, read_rows, stored_keys
from ibvs_youla.exceptions import InvalidParameterError
from ibvs_youla.files import WRITE_DELAY_ENV, is_temporary
from ibvs_youla.simulation.results import SimulationResult

CONTROLLERS = ("ibvs-current", "pbvs", "ibvs-desired")
DEFINITION = {"family": "free-planar", "cases": 12, "controllers": CONTROLLERS, "seed": 3, "duration": 20.0}
RUNS = 36
BATCH_ROWS = 3  # rows per Parquet file of the CLI's campaigns
CLI_ARGS = [
    "campaign",
    "--family",
    "free-planar",
    "--cases",
    "12",
    "--controllers",
    ",".join(CONTROLLERS),
    "--seed",
    "3",
    "--duration",
    "20",
    "--batch-rows",
    str(BATCH_ROWS),
    "--no-progress",
]
TIMED = ("wall_s", "update_median_us", "update_p95_us")
PYTHON_CLI = "import sys; from ibvs_youla.cli import main; sys.exit(main(sys.argv[1:]))"


def _cli(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _one_line(err):
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("ibvs-youla: error: ") and "Traceback" not in err, err
    return lines[0]


def _snapshot(path: Path) -> dict[str, bytes] | None:
    """Every file under ``path`` with its bytes, or None when it does not exist."""
    if not path.exists():
        return None
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def assert_same_rows(rows: pd.DataFrame, reference: pd.DataFrame) -> None:
    """One row per (case, controller), all of them, equal to the reference but for the timings."""
    assert len(rows) == RUNS and not rows.duplicated(["case", "controller"]).any()
    assert not rows["key"].duplicated().any()
    a, b = rows.set_index("key").sort_index(), reference.set_index("key").sort_index()
    assert list(a.index) == list(b.index)
    for column, kind in COLUMNS.items():
        if column in TIMED or column == "key":
            continue
        if kind is float:
            np.testing.assert_allclose(a[column], b[column], rtol=1e-12, atol=1e-12, equal_nan=True)
        else:
            assert list(a[column]) == list(b[column]), column


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The campaign run in this process, without Dask: its folder and rows."""
    out = tmp_path_factory.mktemp("campaign") / "reference"
    summary = run_campaign(CampaignDefinition(**DEFINITION), out, workers=0, progress=False, batch_rows=8)
    assert (summary.runs, summary.stored_before, summary.ran, summary.errors) == (RUNS, 0, RUNS, 0)
    return out, read_rows(out)


# ----------------------------------------------------------------------------- one process, storage
def test_one_process_stores_every_row_once_and_a_rerun_adds_nothing(reference):
    out, rows = reference
    assert_same_rows(rows, rows)
    assert sorted(zip(rows["case"], rows["controller"], strict=True)) == sorted(
        (case, name) for case in range(12) for name in CONTROLLERS
    )
    on_disk = pd.read_parquet(out / "rows")  # the dataset as any reader sees it
    assert list(on_disk.columns) == list(COLUMNS) and len(on_disk) == RUNS
    assert len(list((out / "rows").glob("part-*.parquet"))) == math.ceil(RUNS / 8)  # 8 rows per part
    # the schema comes from COLUMNS: an all-NaN column (no torque on the free camera) stays float
    assert on_disk["peak_torque_ratio"].dtype == np.float64 and on_disk["peak_torque_ratio"].isna().all()
    assert on_disk["qp_infeasible_frames"].dtype == np.int64 and on_disk["case"].dtype == np.int64
    assert set(rows["outcome"]) == {"reached"}  # every method reaches these 12 cases in 20 s
    stored = json.loads((out / "campaign.json").read_text())
    assert stored == {"format": 1, **json.loads(json.dumps(CampaignDefinition(**DEFINITION).to_dict()))}
    assert stored["settings"] == {"joint_rate_hz": 25.0, "camera_rate_hz": 25.0}  # the free family's
    before = _snapshot(out / "rows")
    again = run_campaign(CampaignDefinition(**DEFINITION), out, workers=0, progress=False)
    assert (again.stored_before, again.ran) == (RUNS, 0)
    assert _snapshot(out / "rows") == before


def test_temporary_files_are_not_rows(tmp_path):
    (tmp_path / "rows").mkdir()
    writer = RowWriter(tmp_path, batch_rows=2, batch_seconds=1e9)
    row = {name: (0.5 if kind is float else 1 if kind is int else "x") for name, kind in COLUMNS.items()}
    row.update(outcome="reached", status="complete")  # values a run has (a part with others is damaged)
    assert writer.add({**row, "key": "a"}) is None and writer.seconds_until_due() > 0.0
    part = writer.add({**row, "key": "b"})  # the second row completes the batch
    assert part is not None and part.name.startswith("part-") and writer.written == 2 and len(writer) == 0
    (tmp_path / "rows" / ".part-crashed.parquet.tmp").write_bytes(b"PAR1 half a file")  # a crash mid-write
    assert stored_keys(tmp_path) == {"a", "b"}
    assert sorted(pd.read_parquet(tmp_path / "rows")["key"]) == ["a", "b"]


def test_series_are_stored_one_file_per_run(tmp_path):
    definition = CampaignDefinition(**{**DEFINITION, "cases": 1, "duration": 2.0})
    run_campaign(definition, tmp_path, workers=0, progress=False, series=True)
    rows = read_rows(tmp_path)
    assert sorted(p.stem for p in (tmp_path / "series").glob("*.npz")) == sorted(rows["key"])
    for row in rows.itertuples():
        result = SimulationResult.load(tmp_path / "series" / f"{row.key}.npz")
        assert result.final_pose_error()[0] == pytest.approx(row.final_position_mm, rel=1e-12)
        assert result.duration == pytest.approx(2.0, abs=1e-9)


def test_definitions_take_their_family_defaults():
    arm = CampaignDefinition("arm-physical", 2, ("ff+fb", "pbvs"))
    assert (arm.plant, arm.camera, arm.duration, arm.settings) == ("dynamic", {"kind": "stereo"}, 20.0, {})
    free = CampaignDefinition("free-nonplanar", 2, ("pbvs",), camera="mono", controller_params={"pbvs": {}})
    assert (free.plant, free.camera, free.duration) == ("free-camera", {"kind": "mono"}, 30.0)
    assert free.settings == {"joint_rate_hz": 25.0, "camera_rate_hz": 25.0} and free.runs == 2
    assert CampaignDefinition.from_dict(json.loads(json.dumps(free.to_dict()))) == free
    with pytest.raises(InvalidParameterError, match="'dynamic' or 'kinematic' for the arm family"):
        CampaignDefinition("arm-virtual", 1, ("pbvs",), plant="free-camera")
    with pytest.raises(InvalidParameterError, match="controller_params"):
        CampaignDefinition("free-planar", 1, ("pbvs",), controller_params={"hybrid": {}})
    with pytest.raises(InvalidParameterError, match="params"):
        CampaignDefinition("free-planar", 1, ("pbvs",), controller_params={"pbvs": {"gian": 1.0}})


def test_without_controllers_every_method_the_plant_takes_runs(capsys, tmp_path):
    code, _, _ = _cli(capsys, "campaign", "--family", "free-planar", "--cases", "1", "--duration", "0.2")
    assert code == 2  # --out is required
    argv = ("campaign", "--family", "free-planar", "--cases", "1", "--duration", "0.2", "--workers", "0")
    code, stdout, _ = _cli(capsys, *argv, "--out", str(tmp_path / "all"))
    # fb, ff+fb command joints; photometric servoes on the image of a scene, which free-planar has not
    twist = [n for n in controllers.names() if n not in ("fb", "ff+fb", "photometric")]
    assert code == 0 and f"1 cases x {len(twist)} methods" in stdout
    assert sorted(read_rows(tmp_path / "all")["controller"]) == sorted(twist)


# ----------------------------------------------------------------------------- a real cluster
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for(predicate, timeout, what, poll=0.05):
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        if predicate():
            return
        time.sleep(poll)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def _stored(out: Path) -> int:
    return len(stored_keys(out)) if (out / "rows").is_dir() else 0


@pytest.fixture
def cluster(tmp_path, processes):
    """A scheduler and two one-thread workers, each a `dask` command-line process on 127.0.0.1."""
    dask = str(Path(sys.executable).with_name("dask"))
    log = tmp_path / "dask-logs"
    log.mkdir()
    address = f"tcp://127.0.0.1:{_free_port()}"
    scheduler = [
        dask,
        "scheduler",
        "--host",
        "127.0.0.1",
        "--port",
        address.rsplit(":", 1)[1],
        "--no-dashboard",
    ]
    with open(log / "scheduler.log", "w") as stream:
        processes.append(subprocess.Popen(scheduler, stdout=stream, stderr=subprocess.STDOUT))
    scheduler_process = processes[-1]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    worker = [dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-nanny", "--no-dashboard"]
    worker += ["--host", "127.0.0.1", "--local-directory", str(tmp_path / "scratch")]
    workers = []
    for k in range(2):
        with open(log / f"worker{k}.log", "w") as stream:
            workers.append(subprocess.Popen(worker, stdout=stream, stderr=subprocess.STDOUT, env=env))
    processes.extend(workers)

    def both_joined():
        text = "".join((log / f"worker{k}.log").read_text() for k in range(2))
        return text.count("Registered to:") == 2

    _wait_for(both_joined, 60, "two workers to register")
    return address, scheduler_process, workers


def test_a_real_cluster_losing_a_worker_stores_every_row_once(tmp_path, reference, cluster, processes):
    address, _, workers = cluster
    out = tmp_path / "distributed"
    # The observer connects first, and the worker is killed as soon as the first batch of rows is
    # stored and a worker runs a task: the compiled runs take 10-50 ms, so the rest of the campaign
    # can finish in the time a new client needs to connect, or while waiting for more rows. The
    # workers are warmed first (imports, compiled kernels of the batch and of PBVS): on a cold cache
    # a worker's first tasks compile for seconds, its rows then arrive together at the end, and the
    # first batch was stored only when nothing was left to run (a clean checkout's CI run, 2026-12-03).
    with Client(address, timeout=10) as observer:  # which worker runs a task now, and its pid
        pids = observer.run(os.getpid)  # worker address -> pid
        warm = lambda texts: __import__("ibvs_youla.campaign.run").campaign.run.run_specs(texts)  # noqa: E731
        observer.run(warm, [spec.to_json() for spec in CampaignDefinition(**DEFINITION).specs()[:6]])
        argv = [*CLI_ARGS, "--out", str(out), "--scheduler", address, "--series"]
        client = subprocess.Popen(
            [sys.executable, "-c", PYTHON_CLI, *argv],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        processes.append(client)
        first_batch = lambda: _stored(out) >= BATCH_ROWS or client.poll() is not None  # noqa: E731
        _wait_for(first_batch, 60, "the first batch of rows", poll=0.005)
        # both workers frozen at once (SIGSTOP): the scheduler's view of who runs what holds still
        # while it is asked, and the campaign cannot end meanwhile; unfrozen to look again if neither
        # had a task
        for worker in workers:
            worker.send_signal(signal.SIGSTOP)
        busy: list[str] = [w for w, tasks in observer.processing().items() if tasks]
        if not busy:
            for worker in workers:
                worker.send_signal(signal.SIGCONT)

            def a_worker_is_busy() -> bool:
                busy[:] = [w for w, tasks in observer.processing().items() if tasks]
                return bool(busy) or client.poll() is not None

            _wait_for(a_worker_is_busy, 10, "a worker running a task", poll=0.005)
        assert busy, "the campaign ended before a worker could be killed mid-task"
        stored_at_kill = _stored(out)
        (victim,) = [w for w in workers if w.pid == pids[busy[0]]]
        victim.send_signal(signal.SIGKILL)
        for worker in workers:
            worker.send_signal(signal.SIGCONT)  # the other goes on (the victim was killed stopped)
    stdout, stderr = client.communicate(timeout=120)
    assert client.returncode == 0, stderr
    assert victim.wait(timeout=10) == -signal.SIGKILL and sum(w.poll() is None for w in workers) == 1
    assert BATCH_ROWS <= stored_at_kill < RUNS  # the worker died mid-campaign, running a task
    assert f"{RUNS} run on scheduler {address}" in stdout
    assert_same_rows(read_rows(out), reference[1])
    assert len(list((out / "series").glob("*.npz"))) == RUNS and not list((out / "series").glob(".*"))


def test_a_stopped_worker_times_out_its_run_and_every_row_is_stored_once(tmp_path, reference, cluster):
    """A worker stopped with SIGSTOP (a frozen node, a run stuck in a solver) holds its runs forever;
    past the run timeout they run again on the other worker, where they finish: every row once, each
    reached (the workers are warmed first: a fresh worker's first run, its imports included, may take
    longer than this test's 3 s timeout on a loaded machine, and would be timed out too)."""
    address, _, workers = cluster
    out = tmp_path / "stopped"
    definition = CampaignDefinition(**DEFINITION)
    outcome: list = []
    with Client(address, timeout=10) as observer:
        pids = observer.run(os.getpid)
        warm = lambda spec: __import__("ibvs_youla.campaign.run").campaign.run.run_spec(spec)  # noqa: E731
        observer.run(warm, definition.specs()[0].to_json())  # imports and compiled code, on both workers
        thread = threading.Thread(
            target=lambda: outcome.append(
                run_campaign(
                    definition, out, scheduler=address, progress=False, batch_rows=3, run_timeout=3.0
                )
            ),
            daemon=True,
        )
        thread.start()
        busy: list[str] = []

        def a_worker_is_busy() -> bool:
            busy[:] = [w for w, tasks in observer.processing().items() if tasks]
            return bool(busy) or not thread.is_alive()

        _wait_for(a_worker_is_busy, 30, "a worker running a task", poll=0.005)
        assert busy, "the campaign ended before a worker could be stopped"
        (victim,) = [w for w in workers if w.pid == pids[busy[0]]]
        victim.send_signal(signal.SIGSTOP)
        try:
            t0 = time.monotonic()
            thread.join(timeout=45)
            assert not thread.is_alive(), "the campaign hangs on the stopped worker"
            assert time.monotonic() - t0 < 45
        finally:
            victim.send_signal(signal.SIGCONT)
            victim.kill()
    (summary,) = outcome
    rows = read_rows(out)
    assert len(rows) == RUNS and not rows["key"].duplicated().any() and summary.ran == RUNS
    assert set(rows["outcome"]) == {"reached"}, rows.loc[rows["outcome"] != "reached", "error"].tolist()
    assert_same_rows(rows, reference[1])


@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_the_run_timeout_is_finite_and_positive(capsys, tmp_path, value):
    with pytest.raises(InvalidParameterError, match="run_timeout"):
        run_campaign(CampaignDefinition(**DEFINITION), tmp_path / "api", workers=0, run_timeout=value)
    assert not (tmp_path / "api").exists()
    for command in ("campaign", "robustness"):
        argv = [command, "--family", "free-planar", "--cases", "1", "--run-timeout", str(value)]
        argv += ["--axis", "noise"] if command == "robustness" else []
        code, stdout, err = _cli(capsys, *argv, "--out", str(tmp_path / command))
        assert code == 2 and stdout == "" and "--run-timeout" in _one_line(err)
        assert not (tmp_path / command).exists()


def test_a_lost_scheduler_is_one_line_and_keeps_the_rows(tmp_path, cluster, processes):
    """The workers warmed first and frozen (SIGSTOP) when two batches are stored, then the scheduler
    killed: the campaign cannot finish in between (as the worker-killing test above)."""
    address, scheduler, workers = cluster
    out = tmp_path / "lost"
    with Client(address, timeout=10) as observer:
        warm = lambda texts: __import__("ibvs_youla.campaign.run").campaign.run.run_specs(texts)  # noqa: E731
        observer.run(warm, [spec.to_json() for spec in CampaignDefinition(**DEFINITION).specs()[:6]])
    client = subprocess.Popen(
        [sys.executable, "-c", PYTHON_CLI, *CLI_ARGS, "--out", str(out), "--scheduler", address],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    processes.append(client)
    _wait_for(lambda: _stored(out) >= 6 or client.poll() is not None, 60, "two batches", poll=0.005)
    for worker in workers:
        worker.send_signal(signal.SIGSTOP)  # killed stopped at teardown (the processes fixture)
    scheduler.send_signal(signal.SIGKILL)
    _, stderr = client.communicate(timeout=60)
    line = _one_line(stderr)
    assert client.returncode == 1 and f"scheduler {address}: lost the connection" in line
    rows = read_rows(out)
    assert 6 <= len(rows) < RUNS and f"the {len(rows)} rows returned by this call are stored" in line
    assert not rows["key"].duplicated().any()


class _WriterThatKillsTheScheduler:
    """A row writer whose first due-time question (the campaign's thread between submitting its runs
    and waiting for them) kills the scheduler and returns once the client gave up reconnecting."""

    def __init__(self, writer, scheduler, client):
        self.writer, self.scheduler, self.client, self.asked = writer, scheduler, client, False

    def __getattr__(self, name):
        return getattr(self.writer, name)

    def __len__(self):
        return len(self.writer)

    def seconds_until_due(self):
        if not self.asked:
            self.asked = True
            _kill_and_wait_for_the_client_to_close(self.scheduler, self.client)
        return self.writer.seconds_until_due()


def _kill_and_wait_for_the_client_to_close(scheduler, client):
    scheduler.send_signal(signal.SIGKILL)
    scheduler.communicate(timeout=30)
    _wait_for(lambda: client.status == "closed", 60, "the client to close")


def _listening(port):
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0


@pytest.mark.parametrize("closes", ["before the call", "between submitting and waiting"])
def test_a_client_that_gave_up_reconnecting_is_a_lost_scheduler(tmp_path, processes, closes):
    """The CI failure of 2026-12-03: the client gave up reconnecting to a killed scheduler and closed
    while the campaign's thread was busy; Dask's module-level wait() then found no default client ("No
    clients found", reported as an internal error), and client.map on a closed client raises
    ClosedClientError. Both are the lost scheduler's one line. A scheduler with no workers keeps the
    runs pending; the scheduler is killed, and the client closed, before the call or between the
    runs' submission and the wait for them, so the order is certain."""
    from ibvs_youla.campaign import storage
    from ibvs_youla.campaign.runner import SchedulerError

    dask = str(Path(sys.executable).with_name("dask"))
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    command = [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"]
    processes.append(subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    scheduler = processes[-1]
    _wait_for(lambda: _listening(port), 60, "the scheduler to listen")
    definition = CampaignDefinition(**{**DEFINITION, "cases": 2, "controllers": ("pbvs",)})
    storage.create_folder(tmp_path, definition.to_dict())
    summary = runner.CampaignSummary(tmp_path, 2, 0)
    bar = runner._progress_bar(2, 0, False)
    client = Client(address, timeout=5)  # gives up reconnecting after 5 s
    try:
        writer = storage.RowWriter(tmp_path, 100, 1e9)
        if closes == "before the call":
            _kill_and_wait_for_the_client_to_close(scheduler, client)
        else:
            writer = _WriterThatKillsTheScheduler(writer, scheduler, client)
        with pytest.raises(SchedulerError, match=f"scheduler {address}: lost the connection, runs cancelled"):
            specs = definition.specs()
            runner._run_dask(client, specs, writer, summary, bar, tmp_path, False, threading.Event())
        assert closes == "before the call" or writer.asked  # killed between submit and wait
    finally:
        client.close()


def test_a_killed_client_resumes_with_the_same_command(tmp_path, reference, processes):
    import psutil

    out = tmp_path / "interrupted"
    command = [sys.executable, "-c", PYTHON_CLI, *CLI_ARGS, "--out", str(out), "--workers", "2"]
    first = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    processes.append(first)
    _wait_for(lambda: _stored(out) >= 6 or first.poll() is not None, 90, "two batches", poll=0.005)
    first.send_signal(signal.SIGSTOP)  # no more rows while its workers are listed (it is killed stopped)
    children = psutil.Process(first.pid).children(recursive=True)  # the local cluster's workers
    first.send_signal(signal.SIGKILL)
    first.communicate(timeout=30)
    stored_at_kill = _stored(out)
    assert first.returncode == -signal.SIGKILL and 6 <= stored_at_kill < RUNS
    assert len(children) >= 2
    _, alive = psutil.wait_procs(children, timeout=20)  # the workers follow their client
    for proc in alive:  # (never expected: killed by id so that the test leaves nothing behind)
        proc.kill()
    assert not alive
    second = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert second.returncode == 0, second.stderr
    assert f"{stored_at_kill} stored before, {RUNS - stored_at_kill} run on 2 local workers" in second.stdout
    assert_same_rows(read_rows(out), reference[1])


class _FakeFuture:
    def __init__(self, spec_json, killed):
        self.spec = json.loads(spec_json)
        self.status, self.value = ("error", None) if killed else ("finished", run_spec_json(spec_json))
        self.key = f"run-{self.spec['case']}"

    def result(self):
        return self.value

    def exception(self):
        from types import SimpleNamespace

        from distributed.scheduler import KilledWorker

        return KilledWorker(self.key, SimpleNamespace(address="tcp://127.0.0.1:1"), 2)

    def release(self):
        pass


class _ClusterWithAKiller:
    """A Dask client stand-in: the run of case 1 kills its worker, and the scheduler blames the runs
    submitted with it that had not finished (case 2: Dask's KilledWorker for each run on the dying worker)."""

    def __init__(self):
        self.submissions = []

    def map(self, function, specs, pure, retries):
        cases = [json.loads(s)["case"] for s in specs]
        self.submissions.append(cases)
        return [_FakeFuture(s, killed=1 in cases and json.loads(s)["case"] >= 1) for s in specs]

    def nthreads(self):
        return {"tcp://127.0.0.1:1": 1}

    status = "running"  # a Dask client's, until it gives its scheduler up

    def as_current(self):  # the loop waits on this client, not the process's default one
        return contextlib.nullcontext()


def run_spec_json(spec_json):
    from ibvs_youla.campaign.run import run_spec

    return run_spec(spec_json)


def test_runs_blamed_for_a_dead_worker_run_again_alone_and_only_the_killer_is_an_error(tmp_path, monkeypatch):
    import distributed

    from ibvs_youla.campaign import storage

    monkeypatch.setattr(distributed, "wait", lambda futures, timeout, return_when: (set(futures), set()))
    definition = CampaignDefinition(**{**DEFINITION, "cases": 3, "controllers": ("pbvs",)})
    storage.create_folder(tmp_path, definition.to_dict())
    writer = storage.RowWriter(tmp_path, 100, 1e9)
    summary = runner.CampaignSummary(tmp_path, 3, 0)
    client = _ClusterWithAKiller()
    bar = runner._progress_bar(3, 0, False)
    runner._collect(client, definition.specs(), writer, summary, bar, tmp_path, False, threading.Event())
    writer.flush()
    assert client.submissions[0] == [0, 1, 2]  # together; then each blamed run alone, after the others
    assert sorted(client.submissions[1:]) == [[1], [2]]
    rows = read_rows(tmp_path).sort_values("case")
    assert list(rows["outcome"]) == ["reached", "error", "reached"] and summary.errors == 1
    assert rows["error"].iloc[1].startswith("KilledWorker: ") and rows["error"].iloc[0] == ""


def _runs_done(log: Path) -> int:
    """The last count of the progress bar in a stderr file ("campaign: ... 7/36 [...]")."""
    import re

    counts = re.findall(rf"(\d+)/{RUNS}\b", log.read_text(errors="replace")) if log.is_file() else []
    return int(counts[-1]) if counts else 0


def test_a_terminated_client_flushes_its_rows_and_resumes(tmp_path, reference, processes):
    """SIGTERM (a batch system's stop) acts as Ctrl-C: rows returned before it are written, exit 130."""
    out, log = tmp_path / "terminated", tmp_path / "stderr.txt"
    command = [sys.executable, "-c", PYTHON_CLI, *CLI_ARGS, "--out", str(out), "--workers", "0"]
    command[command.index("--batch-rows") + 1] = "1000"  # nothing is written before the signal
    first_command = [arg for arg in command if arg != "--no-progress"]  # its bar counts the finished runs
    with open(log, "w") as stderr:
        first = subprocess.Popen(first_command, stdout=subprocess.DEVNULL, stderr=stderr, text=True)
    processes.append(first)
    _wait_for(lambda: _runs_done(log) >= 2 or first.poll() is not None, 120, "two runs to finish")
    assert _stored(out) == 0  # finished, not written
    first.send_signal(signal.SIGTERM)
    first.wait(timeout=30)
    stored = _stored(out)
    assert first.returncode == 130, log.read_text()
    assert 2 <= stored < RUNS
    last_line = log.read_text().replace("\r", "\n").strip().splitlines()[-1]
    assert last_line == (
        f"ibvs-youla: interrupted: {stored} of {RUNS} runs stored in {out}; rerun the same command to resume"
    )
    second = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert second.returncode == 0, second.stderr
    assert f"{stored} stored before, {RUNS - stored} run on this process" in second.stdout
    assert_same_rows(read_rows(out), reference[1])


def test_a_sigterm_that_a_run_swallows_still_stops_the_campaign(tmp_path, monkeypatch):
    """The signal's KeyboardInterrupt can land where a library turns it into an error of its own (or a
    finalizer drops it): the run then ends as an error row. The client still stops after that run,
    stores the runs before it and not that one (it was interrupted, not failed)."""
    from ibvs_youla.campaign import run as run_module

    real = run_module.run_spec_with_result
    calls = []

    def third_run_swallows_the_signal(spec):
        calls.append(spec.key)
        if len(calls) < 3:
            return real(spec)
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)  # the handler raises here
        except BaseException as err:  # what a careless library does
            return run_module.error_row(spec, RuntimeError(f"wrapped {err!r}")), None
        raise AssertionError("SIGTERM did not interrupt the run")

    monkeypatch.setattr(run_module, "run_spec_with_result", third_run_swallows_the_signal)
    out = tmp_path / "swallowed"
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        run_campaign(CampaignDefinition(**DEFINITION), out, workers=0, progress=False)
    rows = read_rows(out)
    keys = set(rows["key"])  # the two pbvs runs before the third, and the two batches of classical IBVS
    assert len(calls) == 3 and set(calls[:2]) <= keys and calls[2] not in keys and len(keys) == 2 + 2 * 12
    assert rows["outcome"].ne("error").all()
    assert signal.getsignal(signal.SIGTERM) is before  # the campaign's handler is gone again
    # nothing of the signal outlives its campaign: the next one, here or in a thread, runs to the end
    monkeypatch.setattr(run_module, "run_spec_with_result", real)
    small = {**DEFINITION, "cases": 1}
    outcome = []
    thread = threading.Thread(  # off the main thread: no handler of its own, so nothing to reset a flag
        target=lambda: outcome.append(
            run_campaign(CampaignDefinition(**small), tmp_path / "thread", workers=0, progress=False).ran
        )
    )
    thread.start()
    thread.join(timeout=120)
    assert outcome == [3]
    assert run_campaign(CampaignDefinition(**small), tmp_path / "next", workers=0, progress=False).ran == 3


def _temporaries(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob(".*") if is_temporary(p.name)) if folder.is_dir() else []


def _no_delay() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k != WRITE_DELAY_ENV}


@pytest.mark.slow
def test_a_client_killed_inside_a_write_resumes_and_a_second_client_is_refused(
    tmp_path, reference, processes
):
    """Extends the test above: the kill lands inside a part's write, and a second client meets the lock."""
    out = tmp_path / "locked"
    create_folder(out, CampaignDefinition(**DEFINITION).to_dict())  # so the first delayed write is a part
    command = [sys.executable, "-c", PYTHON_CLI, *CLI_ARGS, "--out", str(out), "--workers", "0"]
    first = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**_no_delay(), WRITE_DELAY_ENV: "120"},  # its first part stays half-written
    )
    processes.append(first)
    lock = out / ".lock"

    def writing() -> bool:
        return (
            lock.exists() and lock.read_text().strip() == str(first.pid) and bool(_temporaries(out / "rows"))
        )

    _wait_for(writing, 120, "the first client inside a write")
    run = {"capture_output": True, "text": True, "timeout": 120, "check": False, "env": _no_delay()}
    second = subprocess.run(command, **run)
    assert second.returncode == 1 and _one_line(second.stderr) == (
        f"ibvs-youla: error: {out}: another client (pid {first.pid}) is running this campaign "
        "(it holds .lock)"
    )
    first.send_signal(signal.SIGKILL)
    first.communicate(timeout=30)
    (half,) = _temporaries(out / "rows")
    assert _stored(out) == 0
    third = subprocess.run(command, **run)
    assert third.returncode == 0, third.stderr
    assert f"0 stored before, {RUNS} run on this process" in third.stdout  # the dead client's lock was free
    assert not half.exists() and not _temporaries(out / "rows")
    assert_same_rows(read_rows(out), reference[1])


@pytest.mark.slow
def test_two_clients_started_together_store_every_row_once(tmp_path, reference, processes):
    out = tmp_path / "together"
    command = [sys.executable, "-c", PYTHON_CLI, *CLI_ARGS, "--out", str(out), "--workers", "0"]
    env = {**_no_delay(), WRITE_DELAY_ENV: "0.05"}
    both = [
        subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        for _ in range(2)
    ]
    processes.extend(both)
    finished = [(proc.communicate(timeout=180)[1], proc.returncode) for proc in both]
    assert 0 in [code for _, code in finished]
    for stderr, code in finished:
        if code != 0:  # refused at the lock: one line, exit 1
            assert code == 1 and "is running this campaign (it holds .lock)" in _one_line(stderr)
    assert_same_rows(read_rows(out), reference[1])
    assert not _temporaries(out) and not _temporaries(out / "rows")


# ----------------------------------------------------------------------------- bad input
FREE = ["campaign", "--family", "free-planar", "--cases", "2", "--duration", "1"]


@pytest.mark.parametrize(
    ("argv", "fragments"),
    [
        ((*FREE, "--controllers", "pbvs,pid"), ["'pid'", "ibvs-current"]),
        (
            (*FREE, "--controllers", "pbvs,pbvs[gain=2"),
            ["--controllers", "'pbvs,pbvs[gain=2'", "name[key=value"],
        ),
        ((*FREE, "--controllers", "pbvs[gain=2],pbvs[gain=2]"), ["given twice", "pbvs[gain=2]"]),
        ((*FREE, "--controllers", "pbvs[wobble=1]"), ["wobble", "parameters of 'pbvs'"]),
        ((*FREE, "--controllers", "pbvs,ff+fb"), ["'ff+fb'", "joint_position", "camera twist"]),
        ((*FREE, "--controllers", "pbvs", "--plant", "dynamic"), ["'dynamic'", "'free-camera'"]),
        (
            ("campaign", "--cases", "2", "--controllers", "pbvs", "--plant", "free-camera"),
            ["'free-camera'", "arm family 'arm-physical'"],
        ),
        ((*FREE, "--seed", "1.5"), ["--seed", "'1.5'", "integers >= 0"]),
        ((*FREE, "--seed", "-2"), ["--seed", "'-2'"]),
        ((*FREE, "--cases", "0"), ["--cases", "'0'", ">= 1"]),
        ((*FREE, "--family", "free-spherical"), ["'free-spherical'", "'free-planar'"]),
        ((*FREE, "--scheduler", "nowhere"), ["--scheduler", "'nowhere'", "tcp://"]),
        ((*FREE, "--scheduler", "tcp://127.0.0.1:1", "--workers", "2"), ["--workers", "--scheduler"]),
    ],
)
def test_bad_arguments_exit_2_and_write_nothing(capsys, tmp_path, argv, fragments):
    out = tmp_path / "out"
    code, stdout, err = _cli(capsys, *argv, "--out", str(out))
    assert code == 2 and stdout == ""
    line = _one_line(err)
    for fragment in fragments:
        assert fragment in line
    assert not out.exists()


def test_missing_arguments_exit_2(capsys):
    code, _, err = _cli(capsys, "campaign", "--cases", "3")
    assert code == 2 and "--out" in _one_line(err)


def test_an_unreachable_scheduler_exits_1_and_writes_nothing(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(runner, "CONNECT_TIMEOUT_S", 1.0)
    out = tmp_path / "out"
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    t0 = time.monotonic()
    code, _, err = _cli(capsys, *FREE, "--controllers", "pbvs", "--out", str(out), "--scheduler", address)
    assert code == 1 and f"scheduler {address}: cannot connect" in _one_line(err)
    assert time.monotonic() - t0 < 10.0 and not out.exists()


def test_a_folder_of_another_campaign_or_other_files_is_refused(capsys, tmp_path):
    out = tmp_path / "out"
    code, stdout, _ = _cli(capsys, *FREE, "--controllers", "pbvs", "--out", str(out), "--workers", "0")
    assert code == 0 and "0 stored before, 2 run on this process" in stdout
    before = _snapshot(out)
    code, _, err = _cli(capsys, *FREE, "--controllers", "pbvs", "--seed", "7", "--out", str(out))
    line = _one_line(err)
    assert code == 1 and "holds another campaign" in line and "seed: stored 0, given 7" in line
    assert _snapshot(out) == before
    code, stdout, _ = _cli(capsys, *FREE, "--controllers", "pbvs", "--out", str(out), "--workers", "0")
    assert code == 0 and "2 of 2 runs stored, nothing to run" in stdout and _snapshot(out) == before
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    code, _, err = _cli(capsys, *FREE, "--controllers", "pbvs", "--out", str(other), "--workers", "0")
    assert code == 1 and "holds other files (notes.txt)" in _one_line(err)
    assert _snapshot(other) == {"notes.txt": b"mine"}


def test_campaign_help(capsys):
    code, out, _ = _cli(capsys, "campaign", "--help")
    assert code == 0 and out.startswith("usage: ibvs-youla campaign")
    assert "--scheduler" in out and "--workers" in out and "--series" in out
