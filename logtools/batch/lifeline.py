"""Workers end with the batch that started them.

A batch killed with ``kill -9`` (or by the out-of-memory killer) runs no clean-up: its local
workers, blocked on the pool's pipe, used to stay alive (~140 MB each) long after (issue 34).
Each worker therefore ties itself to its driver when it starts:

* on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` (through ``ctypes``): the kernel kills the
  worker the moment its parent ends (the pool creates its workers from the driver's main thread,
  whose end is the process's end);
* everywhere, as a fallback (another OS, a parent that died before the ``prctl``, a Ray worker
  whose parent is Ray's raylet and not the driver), a daemon thread that looks at the driver
  every :data:`POLL_S` seconds and ends the worker (``os._exit``) once it is gone.

The driver is named by a :class:`Lifeline`: its pid, the start time of that pid (so that a pid
reused by another process is not taken for the driver) and the machine's boot id (a Ray worker
on another machine cannot see the driver's pid; it leaves the driver to Ray there).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from dataclasses import dataclass

__all__ = ["POLL_S", "Lifeline", "tie_to_parent", "watch_driver"]

POLL_S = 1.0
"""How often the fallback watch looks at the driver (seconds)."""

_PR_SET_PDEATHSIG = 1
_WATCHING: set[int] = set()  # drivers this process already watches (one thread each)


def _boot_id() -> str:
    try:
        with open("/proc/sys/kernel/random/boot_id") as fh:
            return fh.read().strip()
    except OSError:
        return ""


def _start_ticks(pid: int) -> int | None:
    """When ``pid`` started (clock ticks since boot, from ``/proc``), or None if it does not
    exist (or has ended: a zombie counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            raw = fh.read()
    except OSError:
        return None
    fields = raw[raw.rfind(b")") + 2 :].split()  # after "pid (name) "
    if not fields or fields[0] in (b"Z", b"X"):
        return None
    return int(fields[19])  # field 22 of stat: starttime


@dataclass(frozen=True)
class Lifeline:
    """The driver a worker belongs to: its pid, that pid's start time, the machine's boot id."""

    pid: int
    start_ticks: int | None
    boot_id: str

    @classmethod
    def of_this_process(cls) -> Lifeline:
        pid = os.getpid()
        return cls(pid, _start_ticks(pid), _boot_id())

    def alive(self) -> bool | None:
        """True while the driver runs, False once it has ended, None when this process cannot
        tell (another machine, or no ``/proc`` and no pid to signal)."""
        if self.boot_id != _boot_id():
            return None
        if self.start_ticks is None:  # no /proc: a signal 0 tells whether the pid exists
            try:
                os.kill(self.pid, 0)
            except ProcessLookupError:
                return False
            except OSError:
                return True
            return True
        return _start_ticks(self.pid) == self.start_ticks


def _set_parent_death_signal() -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return int(libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)) == 0
    except (OSError, AttributeError):
        return False


def watch_driver(driver: Lifeline, poll_s: float = POLL_S) -> None:
    """End this process (``os._exit``) once ``driver`` has ended: checked now, then by a daemon
    thread every ``poll_s`` seconds (started once per driver and process)."""
    if driver.alive() is False:
        os._exit(1)
    if driver.pid in _WATCHING or driver.alive() is None:
        return
    _WATCHING.add(driver.pid)
    stop = threading.Event()

    def _watch() -> None:
        while not stop.wait(poll_s):
            if driver.alive() is False:
                with contextlib.suppress(Exception):
                    sys.stderr.flush()
                os._exit(1)

    threading.Thread(target=_watch, name="logcal-driver-watch", daemon=True).start()


def tie_to_parent(driver: Lifeline) -> None:
    """Make this worker end with ``driver``, its parent: the parent-death signal, then the
    fallback watch (which also catches a parent that ended before the signal was set)."""
    if driver.pid == os.getppid():
        _set_parent_death_signal()
    watch_driver(driver)
