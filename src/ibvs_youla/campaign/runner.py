"""Run a campaign: every method on the same seeded cases, on local processes or a Dask cluster.

The campaign is data (:class:`~.definition.CampaignDefinition`, with the defaults per family).
:func:`run_campaign` builds the specs (:func:`~.cases.generate_cases` then
:func:`~.spec.specs_for`), skips the keys already stored in ``out_dir``
(:func:`~.storage.stored_keys`), and runs the rest:

* by default on a ``distributed.LocalCluster`` of processes with one thread each (a Pinocchio
  ``Data`` must not be shared between threads), one per core;
* with ``scheduler="tcp://host:port"`` on an existing Dask cluster (``Client(address)``), with
  no other change (its workers need this package installed);
* with ``workers=0`` in this process, without Dask (debugging, tiny campaigns).

Specs travel as JSON; the workers return rows (:func:`~.run.run_spec`) and never write. Runs that
one :func:`~ibvs_youla.simulate_batch` call can make together (:func:`~.run.batch_key`: classical
IBVS on the free camera or the kinematic arm) travel as one task of up to :data:`BATCH_RUNS` specs
(:func:`~.run.run_specs`), each of their rows the one it would have alone; the others one per task.
Tasks are submitted with ``pure=False, retries=2`` in a window of a few per worker thread. A worker
that dies loses its current tasks, which the scheduler reruns elsewhere. A run that took
down ``distributed.scheduler.allowed-failures`` (3) workers (``KilledWorker``) may be innocent:
the scheduler blames every run that was on a dying worker, so it is run again, alone on the
cluster, after the others; if it kills its worker again it is stored as an ``"error"`` row.
A batch task that took down workers or ran past the run timeout is split: its runs go on one per
task, each with the guarantees above. A task that raised (``run_spec`` does not, so the cause is the worker's
environment, e.g. this package missing) is not stored: the campaign goes on, and the summary
counts it so that a rerun retries it. Rows are flushed by :class:`~.storage.RowWriter` every
``batch_rows`` rows or ``batch_seconds`` seconds, and on Ctrl-C or SIGTERM (which the client
turns into ``KeyboardInterrupt`` while it runs, so a batch system's stop request loses no
returned row); rerunning the same campaign resumes it: under the folder's lock it deletes what
a killed client left half-written and sets aside a damaged part, saying so in one line on
stderr (logger ``ibvs_youla.campaign.runner``), whose runs then run again
(:func:`~.storage.recover`).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._validation import integer, positive
from ..exceptions import IbvsYoulaError, InvalidParameterError
from .definition import FAMILY_DEFAULTS, CampaignDefinition
from .spec import ExperimentSpec

__all__ = [
    "BATCH_RUNS",
    "FAMILY_DEFAULTS",
    "CampaignDefinition",
    "CampaignSummary",
    "SchedulerError",
    "check_runnable",
    "check_workers",
    "default_workers",
    "max_workers",
    "run_campaign",
    "start_local_cluster",
    "tasks_of",
]

_LOG = logging.getLogger(__name__)
CONNECT_TIMEOUT_S = 10.0  # to reach an existing scheduler [s]
TASKS_PER_THREAD = 4  # tasks in flight per worker thread (at least MIN_WINDOW in all)
MIN_WINDOW = 32
RUN_TIMEOUT_S = 600.0  # default longest run on a worker [s]: a normal run takes seconds
LATE_S = 60.0  # a run running longer than this (or half the run timeout) shows as late [s]
BATCH_RUNS = 50  # most runs of one simulate_batch call in one task


class SchedulerError(IbvsYoulaError):
    """The Dask scheduler cannot be reached, or the cluster lost runs.

    Attributes:
        address: The scheduler's address ("local" for the local cluster).
    """

    def __init__(self, address: str, message: str) -> None:
        self.address = address
        super().__init__(f"scheduler {address}: {message}")


def default_workers() -> int:
    """Cores this process may use (its CPU affinity where the system tells it)."""
    affinity = getattr(os, "sched_getaffinity", None)
    return len(affinity(0)) if affinity is not None else max(1, os.cpu_count() or 1)


def max_workers() -> int:
    """The most worker processes a local cluster may start: twice the cores this process may use.

    A run is single-threaded and CPU-bound, so beyond one worker per core the workers only share
    the cores (twice leaves room for workers that start, wait on the scheduler or write), and each
    worker is a process of about 380 MB (measured after one arm run): a thousand would need 380 GB.
    """
    return 2 * default_workers()


def check_workers(workers: Any) -> int | None:
    """``workers`` if it is None or an integer in [0, :func:`max_workers`].

    Raises:
        InvalidParameterError: anything else, with the bound and why.
    """
    if workers is None:
        return None
    high = max_workers()
    if isinstance(workers, bool) or not isinstance(workers, int) or not 0 <= workers <= high:
        raise InvalidParameterError(
            "workers",
            workers,
            f"an integer in [0, {high}]: 0 runs in this process, and a local cluster has at most twice "
            f"the {default_workers()} cores this process may use (one single-threaded process of "
            "~380 MB per run; more only share the cores)",
        )
    return workers


def check_runnable(definition: CampaignDefinition) -> list[ExperimentSpec]:
    """The specs of ``definition``, once its cases are drawn and one run's recording fits in memory.

    What :func:`run_campaign` (and a robustness study, before its folder) checks before a folder
    is bound: a duration so long that one run's samples (at the least: time, camera pose,
    features, visibility and the plant's and commands' signals) would not fit in the memory
    available now is one refusal here, not an error row per run.

    Raises:
        InvalidParameterError: a case the generator cannot draw (``difficulty``), or a
            ``duration`` whose recording does not fit in memory.
    """
    from .._memory import fits_in_memory
    from ..simulation.recorder import ResultRecorder
    from ..simulation.settings import SimulationSettings

    specs = definition.specs()
    settings = SimulationSettings(**dict(definition.settings or {}))
    free = definition.plant == "free-camera"
    dt = 1.0 / (settings.camera_rate_hz or settings.joint_rate_hz) if free else settings.dt
    ticks = definition.duration / dt  # type: ignore[operator]
    first = specs[0].scenario  # its markers: in the base (markers_O), or on the tool eye-to-hand (markers_E)
    n_points = len(first["markers_O"] if first.get("markers_O") is not None else first["markers_E"])
    per_point = 3 if dict(definition.camera)["kind"] == "stereo" else 2  # type: ignore[arg-type]
    n = 6 if free else definition.make_arm().nq  # joints of the campaign's arm
    signals = {"camera_twist": (6,)} if free else {name: (n,) for name in ("q", "q_true", "dq", "command")}
    n_rows, n_frames = ticks / settings.record_every + 2, ticks / (1 if free else settings.camera_every) + 1
    fits_in_memory(
        ResultRecorder.estimate_bytes(n_rows, n_frames, per_point * n_points, n_points, signals),
        "duration",
        definition.duration,
        f"a shorter duration or a larger settings record_every (now {settings.record_every}: "
        f"{n_rows:.3g} samples of one run are kept)",
    )
    return specs


@dataclass
class CampaignSummary:
    """What one call of :func:`run_campaign` did.

    Attributes:
        out_dir: The campaign folder.
        runs: Runs of the campaign (cases x controllers).
        stored_before: Rows already stored when the call started (skipped).
        ran: Rows stored by this call.
        errors: Rows of this call with the outcome ``"error"``.
        not_stored: Tasks that raised on their worker and were not stored (rerun to retry).
        first_failure: The message of the first of those, or "".
        outcomes: Outcome -> count over the rows of this call.
        wall_s: Wall time of the call, cluster start included [s].
        run_s: Wall time from the first submission to the last row [s].
        workers: Worker threads ("0" in this process).
        other_rows: Stored rows whose key is no run of this definition (rows written by a
            version of the package whose specs serialize differently; they are kept, not rerun).
    """

    out_dir: Path
    runs: int
    stored_before: int
    ran: int = 0
    errors: int = 0
    not_stored: int = 0
    first_failure: str = ""
    outcomes: Counter[str] = field(default_factory=Counter)
    wall_s: float = 0.0
    run_s: float = 0.0
    workers: int = 0
    other_rows: int = 0

    @property
    def runs_per_minute(self) -> float:
        """Rows stored per minute of :attr:`run_s` (NaN when nothing ran)."""
        return 60.0 * self.ran / self.run_s if self.ran and self.run_s > 0.0 else math.nan


def run_campaign(
    definition: CampaignDefinition,
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    series: bool = False,
    batch_rows: int = 20,
    batch_seconds: float = 10.0,
    run_timeout: float = RUN_TIMEOUT_S,
) -> CampaignSummary:
    """Run the runs of ``definition`` not yet stored in ``out_dir`` (module docstring).

    Args:
        definition: The campaign.
        out_dir: Its folder (:mod:`.storage`); created if absent.
        scheduler: Address of an existing Dask scheduler, e.g. ``"tcp://127.0.0.1:8786"``.
        workers: Worker processes of the local cluster (default: one per core, at most
            :func:`max_workers`); 0 runs in this process without Dask. Not with ``scheduler``.
        progress: Show a progress bar (runs done, errors, time left) on stderr.
        series: Also store the full time series of each run made by this call in
            ``out_dir/series/<key>.npz`` (the workers return the result with the row; the
            client writes it). Runs already stored are not rerun for their series.
        batch_rows: Rows per Parquet part (an integer >= 1).
        batch_seconds: Longest time a finished row waits before it is written [s] (finite, > 0).
        run_timeout: Longest time a run may take on a Dask worker (finite, > 0) [s]: a run
            running longer is submitted again, first in line, on another worker (the late one is
            avoided until its run returns), and stored as a ``"timeout"`` row if that copy runs
            longer too; the first copy to return is stored, a later one dropped. It counts from
            when a worker starts the run: leave room for a worker's start-up (imports, compiled
            code) on its first run. Runs in this process (``workers=0``) are not timed.

    Returns:
        The summary; every stored row reads with ``pandas.read_parquet(out_dir + "/rows")``.

    Raises:
        InvalidParameterError: a bad argument, or a campaign that cannot run
            (:func:`check_runnable`); nothing written.
        CampaignStorageError: ``out_dir`` holds another campaign or other files, or another
            client runs it (nothing written).
        SchedulerError: the scheduler cannot be reached within :data:`CONNECT_TIMEOUT_S`
            (nothing written), the cluster lost runs, or every worker has been hung (a run past
            the run timeout) for a run timeout more (what was returned is stored).
    """
    from . import storage

    t_start = time.perf_counter()
    if not isinstance(definition, CampaignDefinition):
        raise InvalidParameterError("definition", type(definition).__name__, "a CampaignDefinition")
    if scheduler is not None and workers is not None:
        raise InvalidParameterError("workers", workers, "None with a scheduler (its workers run the tasks)")
    check_workers(workers)
    integer(batch_rows, "batch_rows", low=1)
    batch_seconds = positive(batch_seconds, "batch_seconds", unit="s")
    run_timeout = positive(run_timeout, "run_timeout", unit="s")
    path = Path(out_dir)
    record = definition.to_dict()
    storage.check_folder(path, record)  # reads only: refuse before connecting or writing
    specs = check_runnable(definition)
    done = storage.stored_keys(path) if path.is_dir() else set()
    summary = CampaignSummary(path, len(specs), sum(s.key in done for s in specs))
    if summary.stored_before == len(specs):  # nothing to run: only tidy what a killed client left
        with storage.client_lock(path):
            _recover(path)
            summary.other_rows = len(storage.stored_keys(path) - {s.key for s in specs})
        summary.wall_s = time.perf_counter() - t_start
        return summary
    with _sigterm_interrupts() as terminated, _quiet_client_logs():  # SIGTERM flushes rows, as Ctrl-C does
        client, cluster = (None, None) if workers == 0 else _connect(scheduler, workers)
        summary.workers = 0 if client is None else sum(_nthreads(client).values())
        try:
            path.mkdir(parents=True, exist_ok=True)
            with storage.client_lock(path):  # before the definition is written: a client that holds
                storage.create_folder(path, record)  # the lock deletes every temporary file it finds
                _recover(path)
                done = storage.stored_keys(path)  # again, under the lock
                pending = [s for s in specs if s.key not in done]
                summary.stored_before = len(specs) - len(pending)
                summary.other_rows = len(done - {s.key for s in specs})
                writer = storage.RowWriter(path, batch_rows, batch_seconds)
                bar = _progress_bar(len(specs), summary.stored_before, progress)
                t_run = time.perf_counter()
                try:
                    if client is None:
                        _run_here(pending, writer, summary, bar, path, series, terminated)
                    else:
                        _run_dask(
                            client, pending, writer, summary, bar, path, series, terminated, run_timeout
                        )
                finally:
                    writer.flush()
                    summary.ran = writer.written
                    summary.run_s = time.perf_counter() - t_run
                    bar.close()
        finally:
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
    summary.wall_s = time.perf_counter() - t_start
    return summary


def _recover(path: Path) -> None:
    """Under the lock: delete a killed client's temporaries, set damaged parts aside (one line each)."""
    from . import storage

    for note in storage.recover(path):
        _LOG.warning("ibvs-youla: %s", note)


def start_local_cluster(workers: int | None = None) -> Any:
    """A ``distributed.LocalCluster`` of ``workers`` one-thread processes (default: one per core).

    What :func:`run_campaign` starts when it is given no scheduler; a caller that runs several
    campaigns in a row (a robustness study) starts one and passes its ``scheduler_address``.
    The caller closes it.

    Raises:
        InvalidParameterError: ``workers`` not None or an integer in [1, :func:`max_workers`].
    """
    from distributed import LocalCluster

    if check_workers(workers) == 0:
        raise InvalidParameterError("workers", 0, "None or >= 1 for a cluster (0 runs in this process)")

    with _workers_ignore_ctrl_c():
        return LocalCluster(
            n_workers=workers or default_workers(),
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # the scheduler's HTTP server (health, metrics) on a free port: its default 8787, taken by
            # another cluster or notebook, printed a warning
            scheduler_kwargs={"dashboard_address": ":0"},
            # the workers' own logs: a worker's failed heartbeat while the cluster closes is logged at
            # ERROR with its traceback; the campaign reports what failed (its runs' errors) itself
            silence_logs=logging.CRITICAL,
        )


def _connect(scheduler: str | None, workers: int | None) -> tuple[Any, Any]:
    """A client of the existing scheduler, or of a new local cluster (and that cluster)."""
    from distributed import Client

    if scheduler is None:
        cluster = start_local_cluster(workers)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S), None
    except (OSError, TimeoutError, ValueError) as err:
        raise SchedulerError(scheduler, f"cannot connect ({' '.join(str(err).split())})") from None


@contextlib.contextmanager
def _quiet_client_logs() -> Iterator[None]:
    """Silence the client's Dask loggers while a campaign holds a client; restore them after.

    When the scheduler goes away, distributed logs the closed batched comm with its traceback
    (``distributed.batched``, at INFO) and its reconnection attempts (``distributed.client``);
    the campaign says it in one line (:class:`SchedulerError`), with the rows it kept.
    """
    loggers = [logging.getLogger(name) for name in ("distributed.batched", "distributed.client")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


@contextlib.contextmanager
def _sigterm_interrupts() -> Iterator[threading.Event]:
    """Turn SIGTERM into ``KeyboardInterrupt`` (as Ctrl-C) while a campaign runs in the main thread.

    A batch system or ``kill`` stops a job with SIGTERM, whose default action ends the process
    without running ``finally``: the rows returned but not yet written would be lost. Yields this
    campaign's own event, set when the signal came (never, off the main thread: no handler).
    """
    terminated = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield terminated
        return

    def interrupt(signum: int, frame: Any) -> None:
        terminated.set()
        raise KeyboardInterrupt(f"signal {signal.Signals(signum).name}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield terminated
    finally:
        signal.signal(signal.SIGTERM, previous)


def _stop_if(terminated: threading.Event) -> None:
    """Raise ``KeyboardInterrupt`` if SIGTERM came, even when its exception never reached the client.

    The handler raises wherever the main thread is: inside a run, an exception raised in a
    finalizer is printed and dropped by Python, and a library may turn it into an error of its
    own, which the run stores as an ``error`` row. Checked before and after every run, before its
    row is stored: the run the signal landed in is not stored (it runs again on resume).
    """
    if terminated.is_set():
        raise KeyboardInterrupt("signal SIGTERM")


@contextlib.contextmanager
def _workers_ignore_ctrl_c() -> Iterator[None]:
    """Ignore SIGINT while the local workers start: they inherit it, and Ctrl-C reaches the client only.

    Ctrl-C signals the terminal's whole process group; without this every worker prints a
    traceback. The client flushes its rows and closes the cluster, which stops the workers.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _address(client: Any) -> str:
    """The scheduler's address; a closed client keeps only what it was given ("unknown" for a cluster)."""
    scheduler = getattr(client, "scheduler", None)
    if scheduler is not None:
        return str(scheduler.address)
    given = getattr(client, "_start_arg", None)
    return given if isinstance(given, str) else "unknown"


def _check_connected(client: Any) -> None:
    """Raise ``CommClosedError`` when the client gave up its scheduler ("closing" or "closed").

    Its futures would never finish: one submitted while it closes is not even cancelled, and a wait
    on it only times out, poll after poll.
    """
    from distributed.comm import CommClosedError

    if client.status in ("closing", "closed"):
        raise CommClosedError(f"the Dask client is {client.status}")


def _nthreads(client: Any) -> dict[str, int]:
    try:
        return dict(client.nthreads())
    except Exception:  # the scheduler is gone: nothing to report
        return {}


def _progress_bar(total: int, initial: int, enabled: bool) -> Any:
    from tqdm.auto import tqdm

    bar = tqdm(
        total=total,
        initial=initial,
        unit="run",
        desc="campaign",
        disable=not enabled,
        file=sys.stderr,
        dynamic_ncols=True,
        smoothing=0.05,
    )
    bar.set_postfix(errors=0, refresh=False)
    return bar


def _store(
    row: dict[str, Any], result: Any, writer: Any, summary: CampaignSummary, bar: Any, path: Path
) -> None:
    from .storage import save_series

    if result is not None:
        save_series(path, row["key"], result)
    writer.add(row)
    summary.outcomes[row["outcome"]] += 1
    summary.errors += row["outcome"] == "error"
    if row["outcome"] == "error":
        bar.set_postfix(errors=summary.errors, refresh=False)
    bar.update(1)


def _run_here(
    pending: Sequence[ExperimentSpec],
    writer: Any,
    summary: CampaignSummary,
    bar: Any,
    path: Path,
    series: bool,
    terminated: threading.Event,
) -> None:
    from . import run

    for task in tasks_of(pending):
        _stop_if(terminated)
        pairs = [run.run_spec_with_result(task[0])] if len(task) == 1 else run.run_specs_with_results(task)
        _stop_if(terminated)
        for row, result in pairs:
            _store(row, result if series else None, writer, summary, bar, path)


def _run_dask(
    client: Any,
    pending: Sequence[ExperimentSpec],
    writer: Any,
    summary: CampaignSummary,
    bar: Any,
    path: Path,
    series: bool,
    terminated: threading.Event,
    run_timeout: float = RUN_TIMEOUT_S,
) -> None:
    from concurrent.futures import CancelledError

    from distributed.client import ClosedClientError
    from distributed.comm import CommClosedError

    address = _address(client)  # while the client still has its scheduler
    try:
        _collect(client, pending, writer, summary, bar, path, series, terminated, run_timeout)
    except (CancelledError, CommClosedError, ClosedClientError):  # the scheduler, or the link to it, is gone
        raise SchedulerError(
            address,
            f"lost the connection, runs cancelled; the {writer.written + len(writer)} rows returned by "
            "this call are stored: rerun the same command to resume",
        ) from None


Task = tuple[ExperimentSpec, ...]  # the runs of one task: one, or several of one batch key


def tasks_of(specs: Sequence[ExperimentSpec], size: int = BATCH_RUNS) -> list[Task]:
    """The specs as tasks in the campaign's order: runs of one batch key together, up to ``size`` a task.

    A spec of no batch key (:func:`~.run.batch_key`) is a task of its own; a task's place is its
    first run's.
    """
    from .run import batch_key

    tasks: list[list[ExperimentSpec]] = []
    filling: dict[str, list[ExperimentSpec]] = {}
    for spec in specs:
        key = batch_key(spec)
        task = None if key is None else filling.get(key)
        if task is not None and len(task) < size:
            task.append(spec)
            continue
        tasks.append([spec])
        if key is not None:
            filling[key] = tasks[-1]
    return [tuple(task) for task in tasks]


def _collect(
    client: Any,
    pending: Sequence[ExperimentSpec],
    writer: Any,
    summary: CampaignSummary,
    bar: Any,
    path: Path,
    series: bool,
    terminated: threading.Event,
    run_timeout: float = RUN_TIMEOUT_S,
) -> None:
    from concurrent.futures import CancelledError

    from distributed import wait
    from distributed.scheduler import KilledWorker

    from .metrics import error_row, timeout_row
    from .run import run_spec, run_spec_with_result, run_specs, run_specs_with_results

    function = run_spec_with_result if series else run_spec
    batch_function = run_specs_with_results if series else run_specs
    queue = list(reversed(tasks_of(pending)))  # pop() from the end keeps the campaign's order
    suspects: list[ExperimentSpec] = []  # killed a worker together with others: rerun alone
    convicted: set[str] = set()  # killed a worker while running alone
    in_flight: dict[Any, Task] = {}
    stale: dict[Any, Task] = {}  # copies on a hung worker: stored if first back, else dropped
    stored: set[str] = set()  # keys stored by this call: a later copy of the same run is dropped
    clock = _RunClock(run_timeout)
    window = _window(client)
    # each run's key (a SHA-256 of its JSON) made once: a row's bookkeeping compares it with every run
    # in flight, up to the window times BATCH_RUNS of them
    keys = {id(spec): spec.key for spec in pending}

    def key(spec: ExperimentSpec) -> str:
        return keys.get(id(spec)) or spec.key

    def submit(tasks: list[Task], retries: int, again: bool = False) -> None:
        """Submit ``tasks``; ``again``: copies of runs that did not return, run next wherever they land."""
        extra = clock.placement(client)
        if again:  # run next wherever they land (a worker runs by priority, then submission)
            extra["priority"] = 1
        singles, batches = [t for t in tasks if len(t) == 1], [t for t in tasks if len(t) > 1]
        if singles:
            runs = [t[0].to_json() for t in singles]
            futures = client.map(function, runs, pure=False, retries=retries, **extra)
            clock.submitted(futures, again)
            in_flight.update(zip(futures, singles, strict=True))
        if batches:
            runs = [[s.to_json() for s in t] for t in batches]
            futures = client.map(batch_function, runs, pure=False, retries=retries, **extra)
            clock.submitted(futures, again)
            in_flight.update(zip(futures, batches, strict=True))

    def done(task: Task) -> bool:
        return all(key(s) in stored for s in task)

    def keep(spec: ExperimentSpec, row: dict[str, Any], result: Any) -> None:
        mine = key(spec)
        if mine in stored:  # a late copy of a run already stored
            return
        stored.add(mine)
        _store(row, result, writer, summary, bar, path)
        # copies of tasks now all stored still running elsewhere are released; those on a hung worker are
        # kept until the end: released, they would free its slots, and the scheduler would send it new
        # runs to hold
        for other in [f for f, t in in_flight.items() if any(key(s) == mine for s in t) and done(t)]:
            in_flight.pop(other)
            other.release()

    def elsewhere(spec: ExperimentSpec) -> bool:
        """Stored, or another copy of the run still running."""
        mine = key(spec)
        return mine in stored or any(mine == key(s) for t in in_flight.values() for s in t)

    while queue or in_flight or suspects:
        _stop_if(terminated)
        _check_connected(client)
        if queue and len(in_flight) < window:
            submit([queue.pop() for _ in range(min(window - len(in_flight), len(queue)))], 2)
        elif not queue and not in_flight and suspects:  # alone on the cluster, after every other run
            spec = suspects.pop(0)
            if key(spec) in stored:
                continue
            convicted.add(key(spec))  # a death from now on is its own
            submit([(spec,)], 0)
        due = writer.seconds_until_due()
        poll = clock.poll_s if due is None else min(max(due, 0.01), clock.poll_s)
        try:
            # this client, not the process's default one: once the client closes (the scheduler lost for
            # longer than its reconnect timeout) there is no default client, and wait() would say only
            # "No clients found"; on this client it raises the futures' cancellation
            with client.as_current():
                finished, _ = wait([*in_flight, *stale], timeout=poll, return_when="FIRST_COMPLETED")
        except TimeoutError:
            finished = set()
        _check_connected(client)  # a closing client's futures time out, poll after poll
        for future in finished:
            if future.status in ("lost", "pending"):  # its result died with a worker: recomputed
                continue
            clock.returned(future.key)
            task = in_flight.pop(future, None) or stale.pop(future, None)
            if task is None:  # released above, as a copy of stored runs
                continue
            if future.status == "finished":
                value = future.result()
                for spec, item in zip(task, [value] if len(task) == 1 else value, strict=True):
                    row, result = item if series else (item, None)
                    keep(spec, row, result)
                continue
            left = [s for s in task if not elsewhere(s)]
            if not left:
                pass  # other copies of its runs are stored or still running
            elif future.status == "error" and isinstance(future.exception(), KilledWorker):
                if len(task) == 1 and key(task[0]) in convicted:
                    keep(task[0], error_row(task[0], future.exception()), None)
                else:  # the scheduler blames every run that was on the dying workers: each again, alone
                    suspects.extend(left)
            elif future.status == "error":
                summary.not_stored += len(left)
                if not summary.first_failure:
                    err = future.exception()
                    summary.first_failure = " ".join(f"{type(err).__name__}: {err}".split())[:300]
            else:
                raise CancelledError(future.key)
            future.release()
        for future, worker, age in clock.overdue(client, in_flight):
            task = in_flight.pop(future)
            stale[future] = task
            if len(task) > 1:  # a batch past the run timeout: its runs again, each a task timed alone
                _LOG.warning(
                    "ibvs-youla: a batch of %d runs took more than %g s on %s; running them one per task",
                    len(task),
                    run_timeout,
                    worker,
                )
                submit([(s,) for s in task if key(s) not in stored], 2, again=True)
                continue
            (spec,) = task
            clock.timed_out(key(spec), worker)
            if clock.attempts[key(spec)] >= 2:
                message = f"timed out: no result after {age:.0f} s on {clock.tried(key(spec))}"
                _LOG.warning("ibvs-youla: run %s %s; stored as a timeout", key(spec), message)
                keep(spec, timeout_row(spec, message, age), None)
            else:  # elsewhere if another worker is healthy; the first copy back is stored
                _LOG.warning(
                    "ibvs-youla: run %s took more than %g s on %s; running it again%s",
                    key(spec),
                    run_timeout,
                    worker,
                    " on another worker" if clock.healthy(client) else "",
                )
                submit([task], 2, again=True)
        if clock.healthy(client):  # runs waiting behind a hung worker's run: move them (else they bounce)
            for future, task in clock.stuck_behind(client, in_flight):
                in_flight.pop(future)
                stale[future] = task
                submit([task], 2, again=True)
        elif clock.stalled_s() > run_timeout:  # no worker can take a run: the campaign cannot go on
            hung = ", ".join(sorted(clock.hung))
            raise SchedulerError(
                _address(client),
                f"every worker has a run past the {run_timeout:g} s run timeout ({hung}) and none returned "
                f"for {clock.stalled_s():.0f} s; the {writer.written + len(writer)} rows returned by this "
                "call are stored: rerun the same command when the workers work",
            )
        late = clock.late(in_flight)
        bar.set_postfix(errors=summary.errors, refresh=False)
        if late:
            bar.set_description(f"campaign ({late} runs late, > {clock.late_s:g} s)", refresh=False)
        else:
            bar.set_description("campaign", refresh=False)
        if writer.seconds_until_due() == 0.0:
            writer.flush()
            window = _window(client)
    for future in stale:  # copies on hung workers of runs stored since
        future.release()


class _RunClock:
    """How long each run has been running on its worker, from what the scheduler says it processes.

    A worker of ``k`` threads runs, of the runs it holds, those it runs already, then the first
    submitted (copies of runs that did not return, submitted with a higher priority, before the
    others; a copy left on a hung worker still holds its slot; a copy does not stop a task that
    runs, which may be a batch of several runs), ``k`` in all; a run's clock starts when it is one
    of those (a run queued behind others on a worker is not timed). A worker with a run past the timeout is
    hung: later runs avoid it while another worker is healthy, and the runs queued on it move
    elsewhere; it is healthy again once that run returns.
    """

    def __init__(self, run_timeout: float) -> None:
        self.run_timeout = run_timeout
        self.late_s = min(LATE_S, run_timeout / 2.0)
        self.poll_s = min(2.0, max(0.05, run_timeout / 10.0))
        self.hung: set[str] = set()
        self.attempts: Counter[str] = Counter()
        self._index: dict[Any, tuple[bool, int]] = {}  # future key -> (not a copy again, submission)
        self._overdue: dict[str, set[Any]] = {}  # hung worker -> the future keys that made it so
        self._none_healthy_since: float | None = None  # since when every worker has been hung
        self._workers: dict[str, list[str]] = {}  # spec key -> workers it timed out on
        self._seen: dict[Any, tuple[str, float]] = {}  # future key -> (worker, first seen there)
        self._started: dict[Any, float] = {}  # future key -> when it became one of the worker's first k
        self._last_poll = -math.inf
        self._processing: dict[str, list[Any]] = {}

    def _poll(self, client: Any, in_flight: dict[Any, Any]) -> None:
        now = time.monotonic()
        if now - self._last_poll < self.poll_s:
            return
        self._last_poll = now
        try:
            processing = {w: list(keys) for w, keys in client.processing().items()}
        except Exception:  # the scheduler is gone, or a client without it: nothing timed
            processing = {}
        threads = _nthreads(client)
        if threads and not any(w not in self.hung for w in threads):
            self._none_healthy_since = self._none_healthy_since or now
        else:
            self._none_healthy_since = None
        seen, started = {}, {}
        for worker, keys in processing.items():
            # run order: what already runs there first (a worker does not stop a task for a copy of a
            # higher priority; a batch task may run for seconds), then by priority and submission
            held = sorted(
                (k for k in keys if k in self._index),
                key=lambda k: (
                    self._seen.get(k, (None,))[0] != worker or k not in self._started,
                    self._index[k],
                ),
            )
            k = max(1, threads.get(worker, 1))
            for n, key in enumerate(held):
                old = self._seen.get(key)
                same = old is not None and old[0] == worker
                seen[key] = old if same else (worker, now)  # type: ignore[assignment]
                if n < k:
                    started[key] = self._started.get(key, now) if same else now
        self._seen, self._started, self._processing = seen, started, processing

    def submitted(self, futures: list[Any], again: bool) -> None:
        """Note new futures, in submission order; ``again``: copies submitted with a higher priority."""
        for future in futures:
            self._index[future.key] = (not again, len(self._index))

    def stalled_s(self) -> float:
        """How long every worker has been hung [s] (0 while one is healthy, or there is none)."""
        since = self._none_healthy_since
        return 0.0 if since is None else time.monotonic() - since

    def returned(self, key: Any) -> None:
        """The task of future ``key`` returned: a worker it made hung works again."""
        for worker, keys in list(self._overdue.items()):
            if key in keys:
                del self._overdue[worker]
                self.hung.discard(worker)

    def overdue(self, client: Any, in_flight: dict[Any, Any]) -> list[tuple[Any, str, float]]:
        """The tasks past the timeout (each counted once: the caller moves them out of ``in_flight``)."""
        self._poll(client, in_flight)
        now, found = time.monotonic(), []
        for future in in_flight:
            started = self._started.get(future.key)
            if started is not None and now - started > self.run_timeout:
                worker = self._seen[future.key][0]
                self.hung.add(worker)
                self._overdue.setdefault(worker, set()).add(future.key)
                found.append((future, worker, now - started))
        return found

    def timed_out(self, key: str, worker: str) -> None:
        """Count a timeout of the run ``key`` on ``worker`` (:attr:`attempts`, :meth:`tried`)."""
        self.attempts[key] += 1
        self._workers.setdefault(key, []).append(worker)

    def stuck_behind(self, client: Any, in_flight: dict[Any, Any]) -> list[tuple[Any, Any]]:
        """The runs queued on a hung worker (not timed there: they wait behind the hung run)."""
        return [
            (f, s) for f, s in in_flight.items() if f.key in self._seen and self._seen[f.key][0] in self.hung
        ]

    def late(self, in_flight: dict[Any, Any]) -> int:
        now = time.monotonic()
        return sum(now - self._started.get(f.key, now) > self.late_s for f in in_flight)

    def healthy(self, client: Any) -> list[str]:
        return [w for w in _nthreads(client) if w not in self.hung]

    def tried(self, key: str) -> str:
        return " then ".join(self._workers.get(key, [])) or "its workers"

    def placement(self, client: Any) -> dict[str, Any]:
        """``client.map`` keywords that keep new runs off hung workers (none while none or all hang)."""
        healthy = self.healthy(client) if self.hung else []
        return {"workers": healthy, "allow_other_workers": False} if healthy else {}


def _window(client: Any) -> int:
    """Tasks to keep in flight: a few per worker thread of the cluster now."""
    return max(MIN_WINDOW, TASKS_PER_THREAD * sum(_nthreads(client).values()))
