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
crash in native code) breaks the pool: the logs it held are tried once more in a new pool, and
recorded as failed if their worker dies again. Like joblib's loky, the pool caps the thread
pools of each worker (OpenMP, OpenBLAS, MKL, polars) at CPUs // workers unless the user set
them, so that N workers do not each start one thread per CPU.
"""

from __future__ import annotations

import contextlib
import itertools
import multiprocessing
import os
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from logtools.batch.archive import LogJob
from logtools.batch.choices import Engine
from logtools.batch.worker import AnalysisOptions, LogOutcome, analyse_job
from logtools.errors import LogcalInputError

__all__ = ["Engine", "run_jobs"]

_ATTEMPTS = 2


def _died(job: LogJob, what: str) -> LogOutcome:
    return LogOutcome(
        job, "failed", error=f"{job.rel}: the worker analysing this log died ({what}), twice; "
        "the log may exhaust memory or crash a native library", error_kind="internal",
    )


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                "POLARS_MAX_THREADS")


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


def _run_local(jobs: Sequence[LogJob], options: AnalysisOptions, workers: int
               ) -> Iterator[LogOutcome]:
    todo = list(jobs)
    tries = {j.id: 0 for j in jobs}
    context = multiprocessing.get_context("spawn")
    while todo:
        with _thread_caps(workers), ProcessPoolExecutor(max_workers=workers,
                                                        mp_context=context) as pool:
            futures: dict[Future[LogOutcome], LogJob] = {
                pool.submit(analyse_job, job, options): job for job in todo
            }
            todo = []
            try:
                # as_completed waits on each future once: linear in the number of logs (a
                # wait(FIRST_COMPLETED) loop re-registers on every pending future per call,
                # quadratic in the number of logs)
                for fut in as_completed(futures):
                    job = futures.pop(fut)
                    try:
                        outcome = fut.result()
                    except BrokenProcessPool as err:
                        tries[job.id] += 1
                        if tries[job.id] >= _ATTEMPTS:
                            yield _died(job, str(err) or "process pool broken")
                        else:
                            todo.append(job)
                        continue
                    yield outcome
            except BaseException:  # interrupted (Ctrl-C, the consumer stopped): start no more
                pool.shutdown(wait=False, cancel_futures=True)
                raise


_IN_FLIGHT_PER_CPU = 4
"""Ray tasks submitted ahead per CPU of the cluster: enough to keep every CPU busy, few enough
that each ``ray.wait`` looks at a short list (waiting on all of 10,000 refs at every step made
the driver's work quadratic in the number of logs)."""


def _run_ray(jobs: Sequence[LogJob], options: AnalysisOptions, workers: int,
             address: str | None) -> Iterator[LogOutcome]:
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
            what = (f"--address {address}: cannot join the Ray cluster" if address
                    else "--engine ray: cannot start a local Ray instance")
            raise LogcalInputError(
                f"{what} ({type(err).__name__}: {str(err).splitlines()[0] if str(err) else ''})"
                "; a cluster started with token authentication needs RAY_AUTH_MODE=token and "
                "its token (RAY_AUTH_TOKEN_PATH or RAY_AUTH_TOKEN) here too; or use "
                "--engine local."
            ) from err
        started = True
    try:
        remote = ray.remote(num_cpus=1, max_retries=_ATTEMPTS - 1)(analyse_job)
        cpus = int(ray.cluster_resources().get("CPU", 0)) or workers
        window = max(16, _IN_FLIGHT_PER_CPU * cpus)
        todo = iter(jobs)
        refs: dict[Any, LogJob] = {}
        while True:
            for job in itertools.islice(todo, window - len(refs)):
                refs[remote.remote(job, options)] = job
            if not refs:
                break
            done, _ = ray.wait(list(refs), num_returns=1)
            for ref in done:
                job = refs.pop(ref)
                try:
                    yield ray.get(ref)
                except Exception as err:  # the task's worker died or Ray lost it
                    yield _died(job, f"{type(err).__name__}: {err}")
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
) -> Iterator[LogOutcome]:
    """Analyse ``jobs`` on ``engine``; yields one outcome per job, in the order they finish.

    Raises:
        LogcalInputError: ``workers`` < 1, or Ray asked for but not installed (or, when the
            outcomes are first asked for, its cluster cannot be joined or started).
    """
    if workers < 1:
        raise LogcalInputError(f"--workers {workers}: expected an integer >= 1.")
    if not jobs:
        return iter(())
    if engine is Engine.RAY:
        return _run_ray(jobs, options, workers, address)
    return _run_local(jobs, options, workers)
