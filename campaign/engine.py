"""Running a campaign's runs on Dask: a `LocalCluster` here, or an existing cluster's scheduler.

Each run is one Dask task, `guarded(runner, spec)`, that calls the application's runner in a
worker process and returns its record: a run that raises is recorded as crashed with its
traceback, and the campaign goes on. A worker that dies under a run (a crash of native code, the
OOM killer) makes Dask retry the run elsewhere and at last give up on it; that too is recorded as
crashed. The campaign keeps only as many runs submitted as the cluster has worker threads,
topping up as runs finish: no run waits on a worker behind another, so a worker that dies takes
down only the run it was running, whatever the scheduler's own queueing (its worker
saturation). Records come back in the order runs finish and go to `on_record` at once, so an
interrupted campaign keeps every finished run. The runner must be a module-level function of a
package the workers can import (Dask sends it by reference): on another machine, the toolchain
must be installed there too.

The local cluster runs one single-threaded worker process per core (`--workers`): the runs hold
the GIL (the emulated CPU, the kernel, NumPy between calls) and a worker's process owns its
emulator. Its scheduler and workers listen on 127.0.0.1 only (the scheduler's HTTP routes on a
free port of it), without the dashboard. The workers ignore Ctrl-C and write their standard
error (Dask's log lines, any traceback) into the campaign's folder, `WORKERS_LOG`, not on the
user's terminal: a worker ending with its campaign can log a heartbeat that met its scheduler
closing, a traceback that says nothing about the runs.

Ctrl-C (or an error) stops the campaign at once: the runs in flight are cancelled and the
workers killed (the finished runs' records are written; `--resume` runs the rest), whenever it
comes, also while the cluster still starts (the workers are born writing into the log, and the
half-started cluster is closed before Dask's exit hook could complain).
"""

from __future__ import annotations

import asyncio
import atexit
import collections
import contextlib
import functools
import logging
import os
import signal
import tempfile
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from campaign.errors import CampaignError
from campaign.plan import Spec
from campaign.record import OK, TIMING, Record, crashed

POLL = 0.05
"""Seconds between two looks for finished runs (and for Ctrl-C)."""
WORKERS_LOG = "workers.log"
"""The local workers' log, in the campaign's folder."""
WORKERS_LEAVE = 10.0
"""Seconds the local workers have to leave before their scheduler closes."""
SCHEDULER_TIMEOUT = 10.0
"""Seconds a campaign tries to reach the Dask scheduler given (--scheduler) before it says it
is not there."""

Runner = Callable[[Spec], dict[str, Any]]
"""An application's run: its spec in, its outcome out (``decisions``, ``stopped_at``, and
``timing`` for what the host's clocks measured)."""


def guarded(runner: Runner, spec: Spec) -> Record:
    """Run `spec` with `runner` in a worker; its record, crashed if it raised."""
    started = time.perf_counter()
    try:
        outcome = runner(spec)
    except Exception:
        return crashed(spec, traceback.format_exc(), time.perf_counter() - started)
    timing = {**outcome.pop(TIMING, {}), "run_seconds": time.perf_counter() - started}
    return {**spec, "status": OK, **outcome, TIMING: timing}


def worker_folder(prefix: str) -> Path:
    """A worker process's build folder for an application's runs (its guest modules built once
    per process): made at the first run that asks, not when the application's module is
    imported (each of its commands imports it), and removed when the process ends."""
    return Path(_folder(prefix).name)


@functools.cache
def _folder(prefix: str) -> tempfile.TemporaryDirectory[str]:
    return tempfile.TemporaryDirectory(prefix=prefix)  # kept by the cache, removed at exit


def _check_scheduler(address: str) -> None:
    """Ask what listens at `address` who it is, in SCHEDULER_TIMEOUT s in all, and refuse
    anything but a Dask scheduler: Client's own timeout covers connecting, not the handshake, so
    a server that accepts and never answers held the campaign forever, and the bytes of a server
    that is not Dask's went to Dask's deserializers, which raised on them (an array of exabytes
    asked for, a dimension too large)."""
    try:
        said = asyncio.run(asyncio.wait_for(_identity(address), SCHEDULER_TIMEOUT))
    except TimeoutError:
        said = f"no answer in {SCHEDULER_TIMEOUT:g} s"
    except OSError as error:
        said = str(error)
    except Exception as error:  # whatever a foreign server's bytes make the decoders raise
        said = f"an answer Dask cannot read ({error})"
    if isinstance(said, dict) and said.get("type") == "Scheduler":
        return
    raise CampaignError(
        f"--scheduler: expected a Dask scheduler at {address}, got {str(said)[:200]}"
    )


async def _identity(address: str) -> object:
    """What the server at `address` says to Dask's ``identity`` request."""
    from distributed.comm import connect

    comm = await connect(address, timeout=SCHEDULER_TIMEOUT)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def default_workers() -> int:
    """One worker per core."""
    return os.cpu_count() or 1


@contextlib.contextmanager
def client(workers: int, scheduler: str | None, log: Path | None = None) -> Iterator[Any]:
    """A Dask client on the scheduler at `scheduler`, or on a new local cluster of `workers`
    single-threaded worker processes (closed on leaving) that log into `log` (None: where Dask
    logs)."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        _check_scheduler(scheduler)
        try:
            connected = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT}s")
        except (OSError, TimeoutError, ValueError) as error:
            raise CampaignError(
                f"--scheduler: expected a Dask scheduler at {scheduler}, got {error}"
            ) from None
        with connected:
            yield connected
        return
    with _workers_born_quiet(log):
        try:
            cluster = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address="127.0.0.1:0",  # the scheduler's routes (health), loopback
                scheduler_kwargs={"dashboard": False},
                silence_logs=logging.ERROR,
            )
        except KeyboardInterrupt:
            _close_half_started()
            raise
    with cluster:
        try:
            with Client(cluster) as local:
                local.register_plugin(_local_worker(log))
                yield local
                _workers_leave(cluster)
        except BaseException:  # Ctrl-C, an error: no run is worth waiting for
            _kill_workers(cluster)
            raise


@contextlib.contextmanager
def _workers_born_quiet(log: Path | None) -> Iterator[None]:
    """Start the local cluster with this process's standard error pointed at `log`, so that its
    worker processes write there from birth: a Ctrl-C in the first second of a campaign reaches
    workers not yet told to ignore it (`_local_worker`), and each printed a KeyboardInterrupt
    traceback on the user's terminal. Standard error comes back whatever happens."""
    if log is None:
        yield
        return
    kept = os.dup(2)
    try:
        _log_into(log)
        yield
    finally:
        os.dup2(kept, 2)
        os.close(kept)


def _kill_workers(cluster: Any) -> None:
    """End the local cluster's worker processes at once (SIGKILL), the scheduler's complaints
    about them silenced: after a Ctrl-C (or an error) the cluster would otherwise wait seconds
    for runs to finish or workers to start before it closes. The records of the finished runs
    are written already; the cancelled runs are left for --resume."""
    _hush()
    for nanny in list(cluster.workers.values()):
        process = getattr(getattr(nanny, "process", None), "process", None)
        pid = getattr(process, "pid", None)
        if pid:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)


def _close_half_started() -> None:
    """Close a local cluster that Ctrl-C stopped while it started, now, its complaints into the
    workers' log, rather than leave it to Dask's exit hook, which fails on workers still
    starting and prints the failure's traceback after the campaign said "interrupted"."""
    from distributed.deploy.spec import close_clusters

    _hush()
    atexit.unregister(close_clusters)
    with contextlib.suppress(Exception):
        close_clusters()


def _hush() -> None:
    """Silence Dask's and asyncio's loggers in this process, which is stopping: they would
    tell the user's terminal of broadcasts to workers gone and of their futures."""
    for talker in ("distributed", "asyncio"):
        logging.getLogger(talker).setLevel(logging.CRITICAL)


def _workers_leave(cluster: Any) -> None:
    """Close the local workers' processes while their scheduler still runs (bounded by
    WORKERS_LEAVE): closed together, a worker's heartbeat can meet a scheduler that has gone and
    log the failure's traceback on the user's terminal, even after a clean interruption. The
    wait is for the cluster's worker processes to end, not for the scheduler to forget them: it
    retires them first, and their processes live on, heartbeats and all, a while after."""
    cluster.scale(0)
    deadline = time.monotonic() + WORKERS_LEAVE
    while cluster.workers and time.monotonic() < deadline:
        time.sleep(POLL)


def _local_worker(log: Path | None) -> Any:
    """A plugin that makes a local worker ignore SIGINT (Ctrl-C reaches every process of the
    terminal's group, and the campaign's own process stops the workers: a worker interrupted
    mid-run would print its traceback) and write its standard error into `log`: Dask's log
    lines (every logger of its, tornado's, the garbage collector's), a traceback, anything.
    Defined here because `distributed` is the campaign extra's, imported when a cluster
    starts."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class LocalWorker(WorkerPlugin):
        def setup(self, worker: Any) -> None:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            if log is not None:
                _log_into(log)

    return LocalWorker()


def _log_into(log: Path) -> None:
    """Point this process's standard error (file descriptor 2, so every handler and every
    library writing there) at the end of `log`."""
    log.parent.mkdir(parents=True, exist_ok=True)
    into = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    os.dup2(into, 2)
    os.close(into)


def execute(
    dask: Any,
    specs: Sequence[Spec],
    runner: Runner,
    on_record: Callable[[Record], None],
    stopping: Callable[[], bool] = lambda: False,
) -> None:
    """Run every spec on the cluster of the client `dask` and hand each record to `on_record`
    as it comes. When `stopping()` turns true (Ctrl-C), the runs left are cancelled and
    KeyboardInterrupt raised, between two records rather than inside Dask's own calls."""
    from distributed import as_completed

    waiting = collections.deque(specs)
    futures: dict[Any, Spec] = {}  # the runs submitted and not yet recorded
    finished = as_completed()

    def top_up() -> None:
        """Submit runs until each worker thread has one (at least one run while any is left;
        workers that join later get theirs as runs finish). Once every run is submitted, the
        scheduler is not asked again."""
        while waiting and len(futures) < max(1, _threads(dask)):
            spec = waiting.popleft()
            future = dask.submit(guarded, runner, spec, key=f"run-{spec['index']}-{spec['seed']}")
            futures[future] = spec
            finished.add(future)

    try:
        top_up()
        while not finished.is_empty():
            if stopping():
                raise KeyboardInterrupt
            ready = finished.next_batch(block=False)
            for future in ready:
                on_record(_record(future, futures.pop(future)))
            if ready:
                top_up()
            else:
                time.sleep(POLL)
    finally:
        dask.cancel(list(futures))


def _threads(dask: Any) -> int:
    """The worker threads of the client's cluster now (the scheduler's total, one round trip
    without the per-worker details)."""
    return int(dask.scheduler_info(n_workers=0).get("total_threads", 0))


def _record(future: Any, spec: Spec) -> Record:
    """The future's record, or a crashed one when its worker died (Dask gave up on the run)."""
    try:
        return future.result()
    except Exception as error:
        text = "".join(traceback.format_exception_only(error)).strip()
        return crashed(spec, f"the run's worker failed: {text}", 0.0)
