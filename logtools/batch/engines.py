"""Where the logs of a batch are analysed: a local process pool (default) or a Ray cluster.

Both run the same function (:func:`logtools.batch.worker.analyse_job`) on the same inputs and
yield its outcomes as they finish, so the outputs do not depend on the engine (tested). Ray is
imported only when asked for (``--engine ray``; ``pip install 'logcal[ray]'``). On a Ray cluster
of several machines (or several nodes on one machine: ``ray start --head`` and
``ray start --address=...``) the archive must be on a file system every node sees at the same
path; the outputs come back to the driver, which alone writes them. A cluster that cannot be
joined (or a local instance that cannot start) is a :class:`LogcalInputError` saying so.

The local pool starts its workers with ``spawn`` (a fresh interpreter: no inherited polars or
BLAS thread pools, which ``fork`` can deadlock). A worker process that dies (out of memory, a
crash in native code, a log stopped past its time budget) breaks the pool: the logs the workers
held are tried once more, one at a time, and recorded as failed (naming the budget) if their
worker dies again; the logs no worker had started are re-submitted. Each log runs under a
memory and a time budget (:mod:`logtools.batch.budgets`), and workers are replaced by fresh
processes every :data:`RECYCLE_EVERY` logs. Workers end with the driver, even one killed with
``kill -9`` (:mod:`logtools.batch.lifeline`: a parent-death signal and a watch of the driver;
on Ray, the watch in each task on the driver's machine). Like joblib's loky, the pool caps the
thread pools of each worker (OpenMP, OpenBLAS, MKL, polars) at CPUs // workers unless the user
set them, so that N workers do not each start one thread per CPU.
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing
import os
import tempfile
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

from logtools.batch.archive import LogJob
from logtools.batch.budgeted import analyse_in_ray, analyse_within_budget
from logtools.batch.budgets import DEFAULT_TIMEOUT_S, Budgets, init_worker
from logtools.batch.choices import Engine
from logtools.batch.lifeline import Lifeline
from logtools.batch.worker import AnalysisOptions, LogOutcome
from logtools.errors import LogcalInputError

__all__ = ["Engine", "run_jobs"]

_ATTEMPTS = 2


RECYCLE_EVERY = 100
"""Logs each local worker analyses before it is replaced by a fresh process (the pool is
renewed every ``workers * RECYCLE_EVERY`` logs), so that the address space thousands of logs
leave behind is returned and ``--log-memory`` bounds one log rather than the history of its
worker. ``ProcessPoolExecutor(max_tasks_per_child=...)`` is not used: on Python 3.11 to 3.13 it
stops scheduling once a worker exits at its limit with tasks queued."""


def _died(
    job: LogJob, what: str, budgets: Budgets, started: float | None, stack: str | None
) -> LogOutcome:
    hard = budgets.hard_stop_s
    if hard is not None and started is not None and time.time() - started >= hard:
        return LogOutcome(
            job,
            "failed",
            error=budgets.time_message(job.rel) + "; its worker was stopped, twice",
            error_kind="input",
            detail=stack or None,
        )
    memory = (
        ""
        if budgets.memory_gib is None
        else f"exceeded the per-log memory budget of {budgets.memory_gib:g} GiB (--log-memory), "
    )
    return LogOutcome(
        job,
        "failed",
        error=f"{job.rel}: the worker analysing this log died ({what}), twice; "
        f"the log may have {memory or 'exhausted memory, '}or crashed a native library",
        error_kind="internal",
        detail=stack or None,
    )


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "POLARS_MAX_THREADS")


@contextlib.contextmanager
def _thread_caps(workers: int) -> Iterator[None]:
    """Set the thread-count variables the workers inherit (spawned processes copy the
    environment when they start), and restore them afterwards."""
    cap = str(max(1, (os.cpu_count() or 1) // workers))
    added = [v for v in _THREAD_VARS if v not in os.environ]
    os.environ.update(dict.fromkeys(added, cap))
    try:
        yield
    finally:
        for v in added:
            os.environ.pop(v, None)


_WORKER_SETUP: str | None = None
"""``"module:function"`` run by each local worker when it starts: a hook of the batch tests
(readers that hang or allocate, registered in spawned workers), not a user option."""


def _held(markers: Path) -> dict[str, tuple[float, str]]:
    """Log id -> (when it started, its worker's stack dump) for every log a worker of this
    pool was analysing (the marker files of
    :func:`~logtools.batch.budgeted.analyse_within_budget`)."""
    held: dict[str, tuple[float, str]] = {}
    for marker in markers.iterdir():
        if not marker.name.isdigit():
            continue
        with contextlib.suppress(OSError, ValueError):
            ident, _, started = marker.read_text().partition("\t")
            if ident:
                stack = ""
                with contextlib.suppress(OSError):
                    stack = (markers / f"{marker.name}.stack").read_text()[-20_000:]
                held[ident] = (float(started), stack)
    return held


def _run_local(
    jobs: Sequence[LogJob], options: AnalysisOptions, workers: int, budgets: Budgets
) -> Iterator[LogOutcome]:
    """A pool of ``workers`` over the logs, renewed every ``workers * RECYCLE_EVERY`` logs.

    When a worker dies, the pool breaks and every log not yet done comes back: the logs a worker
    was analysing at that moment (its marker) have used one try and are retried one at a time in
    a pool of one worker, so that a log that kills its worker again is the only one it takes
    down (recorded as failed); the logs no worker had started are re-submitted as they were."""
    todo = list(jobs)
    suspects: list[LogJob] = []
    tries = {j.id: 0 for j in jobs}
    context = multiprocessing.get_context("spawn")
    while todo or suspects:
        if todo:
            width = workers
            chunk, todo = todo[: workers * RECYCLE_EVERY], todo[workers * RECYCLE_EVERY :]
        else:
            width = 1
            chunk, suspects = suspects[:RECYCLE_EVERY], suspects[RECYCLE_EVERY:]
        with (
            tempfile.TemporaryDirectory(
                prefix="logcal-workers-", ignore_cleanup_errors=True
            ) as markers,
            _thread_caps(width),
            ProcessPoolExecutor(
                max_workers=width,
                mp_context=context,
                initializer=init_worker,
                initargs=(budgets, markers, _WORKER_SETUP, Lifeline.of_this_process()),
            ) as pool,
        ):
            futures: dict[Future[LogOutcome], LogJob] = {
                pool.submit(analyse_within_budget, job, options): job for job in chunk
            }
            held: dict[str, tuple[float, str]] | None = None
            try:
                # as_completed waits on each future once: linear in the number of logs (a
                # wait(FIRST_COMPLETED) loop re-registers on every pending future per call,
                # quadratic in the number of logs)
                for fut in as_completed(futures):
                    job = futures.pop(fut)
                    try:
                        outcome = fut.result()
                    except BrokenProcessPool as err:
                        if held is None:  # which logs the workers held when the pool broke
                            held = _held(Path(markers))
                        if held and job.id not in held:  # never started: not its fault
                            # (no log held at all: the worker died starting; every log counts)
                            (todo if width > 1 else suspects).append(job)
                            continue
                        tries[job.id] += 1
                        if tries[job.id] >= _ATTEMPTS:
                            started, stack = held[job.id]
                            yield _died(
                                job, str(err) or "process pool broken", budgets, started, stack
                            )
                        else:
                            suspects.append(job)
                        continue
                    yield outcome
            except BaseException:  # interrupted (Ctrl-C, the consumer stopped): start no more
                pool.shutdown(wait=False, cancel_futures=True)
                raise


_IN_FLIGHT_PER_CPU = 4
"""Ray tasks submitted ahead per CPU of the cluster: enough to keep every CPU busy, few enough
that each ``ray.wait`` looks at a short list (waiting on all of 10,000 refs at every step made
the driver's work quadratic in the number of logs)."""


def ray_task_options(budgets: Budgets, node_memory: Sequence[float]) -> dict[str, Any]:
    """Options of the Ray task of one log: one CPU, one retry, and the memory budget as its
    ``memory=`` request (bytes; Ray schedules no more tasks on a node than its memory holds,
    and its memory monitor stops a task that takes more). The default budget is lowered to the
    largest node's memory; an explicit budget no node offers is an error (the tasks would wait
    forever).

    Raises:
        LogcalInputError: ``--log-memory`` larger than every node's memory resource.
    """
    opts: dict[str, Any] = {"num_cpus": 1, "max_retries": _ATTEMPTS - 1}
    request = budgets.memory_bytes
    largest = max(node_memory, default=0.0)
    if request is not None and largest > 0 and request > largest:
        if not budgets.memory_default:
            raise LogcalInputError(
                f"--log-memory {budgets.memory_gib:g}: no node of the Ray cluster offers that "
                f"much memory (the largest offers {largest / 2**30:.1f} GiB); lower it."
            )
        request = int(largest)
    if request is not None:
        opts["memory"] = request
    return opts


def _node_memory(ray: Any) -> list[float]:
    with contextlib.suppress(Exception):
        return [
            float(n.get("Resources", {}).get("memory", 0.0)) for n in ray.nodes() if n.get("Alive")
        ]
    return []


def _run_ray(
    jobs: Sequence[LogJob],
    options: AnalysisOptions,
    workers: int,
    address: str | None,
    budgets: Budgets,
) -> Iterator[LogOutcome]:
    try:
        import ray
    except ImportError as err:
        raise LogcalInputError(
            "--engine ray: the ray package is not installed; install it with "
            "pip install 'logcal[ray]' (or use --engine local)."
        ) from err
    started = False
    if not ray.is_initialized():
        try:
            if address:
                ray.init(address=address, log_to_driver=False)
            else:
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        except Exception as err:  # no such cluster, refused token, no shared memory, ...
            what = (
                f"--address {address}: cannot join the Ray cluster"
                if address
                else "--engine ray: cannot start a local Ray instance"
            )
            raise LogcalInputError(
                f"{what} ({type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''})"
                "; a cluster started with token authentication needs RAY_AUTH_MODE=token and "
                "its token (RAY_AUTH_TOKEN_PATH or RAY_AUTH_TOKEN) here too; or use "
                "--engine local."
            ) from err
        started = True
    try:
        remote = ray.remote(**ray_task_options(budgets, _node_memory(ray)))(analyse_in_ray)
        cpus = int(ray.cluster_resources().get("CPU", 0)) or workers
        window = max(16, _IN_FLIGHT_PER_CPU * cpus)
        todo = iter(jobs)
        refs: dict[Any, LogJob] = {}
        driver = Lifeline.of_this_process()  # tasks on this machine end with the driver
        while True:
            for job in itertools.islice(todo, window - len(refs)):
                refs[remote.remote(job, options, budgets, driver)] = job
            if not refs:
                break
            done, _ = ray.wait(list(refs), num_returns=1)
            for ref in done:
                job = refs.pop(ref)
                try:
                    yield ray.get(ref)
                except Exception as err:  # the task's worker died or Ray lost it
                    yield _died(job, f"{type(err).__name__}: {err}", budgets, None, None)
    finally:
        if started:
            ray.shutdown()


def run_jobs(
    jobs: Sequence[LogJob],
    options: AnalysisOptions,
    *,
    engine: Engine = Engine.LOCAL,
    workers: int = 1,
    address: str | None = None,
    budgets: Budgets | None = None,
) -> Iterator[LogOutcome]:
    """Analyse ``jobs`` on ``engine``; yields one outcome per job, in the order they finish,
    each log under ``budgets`` (default: the default memory share, an hour; see
    :mod:`logtools.batch.budgets`).

    Raises:
        LogcalInputError: ``workers`` < 1, or Ray asked for but not installed (or, when the
            outcomes are first asked for, its cluster cannot be joined or started).
    """
    if workers < 1:
        raise LogcalInputError(f"--workers {workers}: expected an integer >= 1.")
    if not jobs:
        return iter(())
    budgets = budgets or Budgets.from_flags(None, DEFAULT_TIMEOUT_S, workers)
    if engine is Engine.RAY:
        return _run_ray(jobs, options, workers, address, budgets)
    return _run_local(jobs, options, workers, budgets)
