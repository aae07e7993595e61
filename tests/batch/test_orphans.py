"""Workers end with their batch (issue 34): a batch whose driver is killed with SIGKILL while its
two workers are busy leaves no process behind (the parent-death signal, and the watch of the
driver as fallback). The bound is generous and polled: a check of what remains, not of speed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import polars as pl
import pytest

from logtools.batch.lifeline import Lifeline, _start_ticks

pytestmark = pytest.mark.slow  # a batch killed and its workers waited for (~10 s)

HERE = Path(__file__).resolve().parent
SAMPLE = HERE.parents[1] / "sample_logs" / "tt_mixed.csv"
DRIVER = f"""
import sys
sys.path[:0] = [{str(HERE)!r}, {str(HERE.parent)!r}]
from pathlib import Path
import budget_readers
budget_readers.install()
import logtools.batch.engines as engines
engines._WORKER_SETUP = "budget_readers:install"
from batch_archive import FAST
from logtools.batch.runner import run_batch
run_batch(Path(sys.argv[1]), Path(sys.argv[2]), options=FAST, workers=2)
"""


def _children(pid: int) -> list[int]:
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            raw = Path(f"/proc/{entry}/stat").read_bytes()
        except OSError:
            continue
        fields = raw[raw.rfind(b")") + 2 :].split()
        if int(fields[1]) == pid:
            found.append(int(entry))
    return found


def _descendants(pid: int) -> list[Lifeline]:
    """Every running process below ``pid``, each named with its start time."""
    out, stack = [], [pid]
    while stack:
        for child in _children(stack.pop()):
            stack.append(child)
            out.append(Lifeline(child, _start_ticks(child), ""))
    return [p for p in out if p.start_ticks is not None]


def _running(proc: Lifeline) -> bool:
    return proc.start_ticks is not None and _start_ticks(proc.pid) == proc.start_ticks


def test_killed_driver_leaves_no_worker(tmp_path: Path) -> None:
    archive = tmp_path / "archive"
    archive.mkdir()
    csv = pl.read_csv(SAMPLE).head(200).write_csv()
    for i in range(4):
        (archive / f"log{i}.hang").write_text(csv)  # each worker sleeps in its reader
    driver = subprocess.Popen(
        [sys.executable, "-c", DRIVER, str(archive), str(tmp_path / "out")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while True:
            workers = (tmp_path / "out").is_dir() and [
                p
                for p in _descendants(driver.pid)
                if b"spawn_main" in Path(f"/proc/{p.pid}/cmdline").read_bytes()
            ]
            if workers and len(workers) >= 2:
                break
            assert driver.poll() is None, "the batch ended before it could be killed"
            assert time.monotonic() < deadline, "the workers never started"
            time.sleep(0.1)
        time.sleep(1.0)  # the workers are in their readers (initialised, tied to the driver)
        left_behind = _descendants(driver.pid)
    finally:
        driver.send_signal(signal.SIGKILL)
        driver.wait()
    deadline = time.monotonic() + 60
    while any(_running(p) for p in left_behind) and time.monotonic() < deadline:
        time.sleep(0.2)
    still = [p.pid for p in left_behind if _running(p)]
    for pid in still:  # do not leave them to the next test
        os.kill(pid, signal.SIGKILL)
    assert still == [], f"processes left behind by the killed batch: {still}"


def test_the_watch_ends_a_process_whose_driver_is_gone() -> None:
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    ghost = Lifeline(gone.pid, 1, Lifeline.of_this_process().boot_id)
    assert ghost.alive() is False
    assert Lifeline.of_this_process().alive() is True
    assert Lifeline(os.getpid(), None, "another machine").alive() is None
    code = (
        "import sys; from logtools.batch.lifeline import Lifeline, watch_driver; "
        f"watch_driver(Lifeline({gone.pid}, 1, Lifeline.of_this_process().boot_id)); "
        "sys.exit(0)"
    )
    ended = subprocess.run([sys.executable, "-c", code], check=False, timeout=60)
    assert ended.returncode == 1  # ended by the watch, before its own exit
