"""Per-log budgets of a batch: how much memory and time one log may take in a worker.

A log is data: whatever it makes a reader do, one log must not stop the batch or take the
machine. Each local worker process therefore runs under

* a memory budget (``--log-memory GIB``): the worker's address space is capped with
  ``RLIMIT_AS`` (``resource.setrlimit``) when it starts; an allocation beyond it fails in the
  worker (``MemoryError`` from Python or numpy, an out-of-memory error from sqlite or polars),
  and the log is recorded as failed, naming the budget. Native code that aborts instead kills
  the worker; the driver's retry path (:mod:`logtools.batch.engines`) names the budget then.
  The cap counts address space, not resident memory: the analysis stack with views maps about
  4 GiB, most of it never touched, hence the floor of the default;
* a time budget (``--log-timeout SECONDS``): a ``SIGALRM`` timer around each log raises
  :class:`LogTimeout` (a ``BaseException``, so that no ``except Exception`` of a reader swallows
  it); code that never returns to the interpreter (a C loop, a blocking read with the signal
  masked) is stopped ``margin`` seconds later by ``faulthandler.dump_traceback_later(...,
  exit=True)``, which ends the worker: the driver records the log as failed (its stack as the
  detail) after one more try, and re-submits the other logs it held.

On Ray the time budget is the same; the memory budget is the task's ``memory=`` resource
request (a scheduling bound), and Ray's own memory monitor, not ``RLIMIT_AS``, stops a task that
takes too much (Ray's workers map its shared object store, which a cap on address space would
break).

No library bounds one call's time and memory inside a reused worker process, hence this module
(``pebble`` and ``loky`` bound time per task by killing the worker, not memory).
"""

from __future__ import annotations

import contextlib
import faulthandler
import math
import os
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from logtools.batch.lifeline import Lifeline, tie_to_parent
from logtools.errors import LogcalInputError

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "Budgets",
    "LogTimeout",
    "active",
    "default_memory_gib",
    "init_worker",
    "marker_file",
    "out_of_memory",
    "set_active",
    "time_limit",
]

GIB = 2**30
DEFAULT_TIMEOUT_S = 3600.0
"""Default time budget per log: an hour (a 4-hour log is analysed by windows in minutes)."""
_MEMORY_CAP_GIB = 8.0
_MEMORY_FLOOR_GIB = 6.0


def default_memory_gib(workers: int) -> float:
    """The default memory budget per log: 80 % of the machine's RAM shared by ``workers``,
    at most 8 GiB and at least 6 GiB (the address space the analysis stack with views maps)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / GIB
    except (ValueError, OSError):
        return _MEMORY_CAP_GIB
    return max(_MEMORY_FLOOR_GIB, min(_MEMORY_CAP_GIB, total * 0.8 / max(1, workers)))


@dataclass(frozen=True)
class Budgets:
    """What one log may take. ``memory_gib``: address space of its worker (None: unbounded);
    ``timeout_s``: wall time (None: unbounded); ``memory_default``: the memory budget is the
    default share, not one the user gave.

    Raises:
        LogcalInputError: a budget that is not a finite number > 0.
    """

    memory_gib: float | None = None
    timeout_s: float | None = DEFAULT_TIMEOUT_S
    memory_default: bool = False

    def __post_init__(self) -> None:
        for flag, v, unit in (
            ("--log-memory", self.memory_gib, "GiB"),
            ("--log-timeout", self.timeout_s, "seconds"),
        ):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise LogcalInputError(f"{flag} {v}: expected {unit} > 0 (0: no budget).")

    @classmethod
    def from_flags(cls, memory_gib: float | None, timeout_s: float, workers: int) -> Budgets:
        """From the command line: ``memory_gib`` None is the default share
        (:func:`default_memory_gib`), 0 is none; ``timeout_s`` 0 is none.

        Raises:
            LogcalInputError: a negative or non-finite value.
        """
        for flag, v in (("--log-memory", memory_gib), ("--log-timeout", timeout_s)):
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise LogcalInputError(f"{flag} {v}: expected a number >= 0 (0: no budget).")
        memory = default_memory_gib(workers) if memory_gib is None else memory_gib
        return cls(
            memory_gib=memory or None,
            timeout_s=timeout_s or None,
            memory_default=memory_gib is None,
        )

    @property
    def memory_bytes(self) -> int | None:
        return None if self.memory_gib is None else int(self.memory_gib * GIB)

    @property
    def hard_stop_s(self) -> float | None:
        """When a log that ignores the alarm is stopped by ending its worker: the budget plus a
        margin (10 %, between 2 s and 60 s) for the alarm's own unwinding."""
        if self.timeout_s is None:
            return None
        return self.timeout_s + min(60.0, max(2.0, 0.1 * self.timeout_s))

    def memory_message(self, rel: str) -> str:
        if self.memory_gib is None:
            return f"{rel}: ran out of memory"
        return (
            f"{rel}: exceeded the per-log memory budget of {self.memory_gib:g} GiB (--log-memory)"
        )

    def time_message(self, rel: str) -> str:
        return (
            f"{rel}: took longer than the per-log time budget of {self.timeout_s:g} s "
            "(--log-timeout)"
        )


class LogTimeout(BaseException):
    """Raised in a worker when a log overruns its time budget (a ``BaseException``: passes
    through every ``except Exception``, as ``KeyboardInterrupt`` does)."""


_OOM_TEXT = (
    "out of memory",
    "cannot allocate memory",
    "memory allocation failed",
    "can't start new thread",
)


def out_of_memory(err: BaseException) -> bool:
    """Whether ``err`` (or an error it was raised from) is an allocation that failed: Python's
    and numpy's ``MemoryError``, ``ENOMEM``, sqlite's or polars' out-of-memory errors, a thread
    that could not get its stack."""
    import errno

    seen: set[int] = set()
    e: BaseException | None = err
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        if isinstance(e, MemoryError):
            return True
        if isinstance(e, OSError) and e.errno == errno.ENOMEM:
            return True
        if any(t in str(e).lower() for t in _OOM_TEXT):
            return True
        e = e.__cause__ or e.__context__
    return False


_ACTIVE: Budgets | None = None
"""The budgets of this worker process (set by :func:`init_worker` or the Ray task)."""
_MARKERS: Path | None = None
_STACK_FILE: IO[str] | None = None


def active() -> Budgets | None:
    """The budgets this process runs under (None: the driver, or no budgets)."""
    return _ACTIVE


def set_active(budgets: Budgets) -> None:
    """Run this process under ``budgets`` (the Ray task's; a local worker's come from
    :func:`init_worker`)."""
    global _ACTIVE
    _ACTIVE = budgets


def marker_file() -> Path | None:
    """The file in which this worker names the log it works on (None: not a local worker)."""
    return None if _MARKERS is None else _MARKERS / str(os.getpid())


def init_worker(
    budgets: Budgets,
    markers: str | None,
    setup: str | None = None,
    driver: Lifeline | None = None,
) -> None:
    """Initializer of a local worker process: tie it to its ``driver`` (it ends when the driver
    does: :mod:`~logtools.batch.lifeline`), cap its address space, remember where to mark the
    log it works on (``markers``: a folder of the driver) and run ``setup``
    (``"module:function"``; the batch tests' hook to register test readers in spawned
    workers, not a user option)."""
    global _ACTIVE, _MARKERS, _STACK_FILE
    if driver is not None:
        tie_to_parent(driver)
    _ACTIVE, _MARKERS = budgets, Path(markers) if markers else None
    if budgets.memory_bytes is not None:
        import resource

        _soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        cap = (
            budgets.memory_bytes
            if hard == resource.RLIM_INFINITY
            else min(hard, budgets.memory_bytes)
        )
        resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    if _MARKERS is not None:
        _STACK_FILE = open(_MARKERS / f"{os.getpid()}.stack", "w")  # noqa: SIM115 (the worker's)
    if setup:
        import importlib

        module, _, name = setup.partition(":")
        getattr(importlib.import_module(module), name)()


@contextlib.contextmanager
def time_limit(budgets: Budgets) -> Iterator[None]:
    """Raise :class:`LogTimeout` in this (main) thread after ``budgets.timeout_s``; end the
    process at ``budgets.hard_stop_s`` if the code never comes back to the interpreter."""
    if budgets.timeout_s is None:
        yield
        return
    hard = budgets.hard_stop_s
    if hard is not None:
        faulthandler.dump_traceback_later(hard, exit=True, file=_STACK_FILE if _STACK_FILE else 2)
    alarm = threading.current_thread() is threading.main_thread()
    previous: Any = None
    if alarm:

        def _raise(_signum: int, _frame: object) -> None:
            raise LogTimeout

        previous = signal.signal(signal.SIGALRM, _raise)
        signal.setitimer(signal.ITIMER_REAL, budgets.timeout_s)
    try:
        yield
    finally:
        if alarm:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        if hard is not None:
            faulthandler.cancel_dump_traceback_later()
