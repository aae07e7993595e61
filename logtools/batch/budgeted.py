"""The batch's job runners under the per-log budgets of :mod:`logtools.batch.budgets`: a log
analysed (:func:`logtools.batch.worker.analyse_job`) in a local worker or a Ray task within its
time budget, the local worker naming the log it holds in its marker file."""

from __future__ import annotations

import time

from logtools.batch.archive import LogJob
from logtools.batch.budgets import Budgets, LogTimeout, active, marker_file, set_active, time_limit
from logtools.batch.lifeline import Lifeline, watch_driver
from logtools.batch.worker import AnalysisOptions, LogOutcome, analyse_job

__all__ = ["analyse_in_ray", "analyse_within_budget"]


def _run(job: LogJob, options: AnalysisOptions, budgets: Budgets) -> LogOutcome:
    t0 = time.perf_counter()
    try:
        with time_limit(budgets):
            return analyse_job(job, options)
    except LogTimeout:
        return LogOutcome(
            job,
            "failed",
            error=budgets.time_message(job.rel),
            error_kind="input",
            seconds=time.perf_counter() - t0,
        )


def analyse_within_budget(job: LogJob, options: AnalysisOptions) -> LogOutcome:
    """:func:`~logtools.batch.worker.analyse_job` in a local worker, under the budgets given to
    :func:`init_worker`; while it runs, the worker's marker file names the log (and when it
    started), so that the driver knows which log a dead worker held."""
    budgets = active() or Budgets(timeout_s=None)
    marker = marker_file()
    if marker is not None:
        marker.write_text(f"{job.id}\t{time.time()}")
    try:
        return _run(job, options, budgets)
    finally:
        if marker is not None:
            marker.write_text("")


def analyse_in_ray(
    job: LogJob, options: AnalysisOptions, budgets: Budgets, driver: Lifeline | None
) -> LogOutcome:
    """The Ray task: the time budget as locally (alarm, then hard stop), no ``RLIMIT_AS`` (the
    memory budget is the task's ``memory=`` request); on the driver's machine the worker ends
    once the driver has (:func:`~logtools.batch.lifeline.watch_driver`)."""
    if driver is not None:
        watch_driver(driver)
    set_active(budgets)
    return _run(job, options, budgets)
