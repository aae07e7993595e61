"""Kill a batch midway (SIGKILL to its process group) and rerun it: finished logs are not
redone, every output file is whole, and a changed log is redone while a touched one is not."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import polars as pl
import pytest
from batch_archive import FAST, sim_log, small_archive

from logtools.batch.runner import load_manifest, run_batch

pytestmark = pytest.mark.slow  # batches killed and rerun (~13 s)

N_LOGS = 7  # 6 simulated + 1 corrupt


def _manifest(out: Path) -> dict[str, dict[str, object]]:
    """The finished logs by name: manifest.json and the journal appended after each log."""
    return {str(e["log"]): e for e in load_manifest(out).values()}


def _check_whole(out: Path) -> None:
    """Every output file (not the leftover temporaries of a kill) is complete."""
    for p in out.rglob("*.json"):
        if ".partial" not in p.name:
            json.loads(p.read_text())
    for p in out.rglob("*.parquet"):
        if ".partial" not in p.name:
            pl.read_parquet(p)


def test_killed_batch_resumes_without_redoing_finished_logs(tmp_path: Path) -> None:
    archive = small_archive(tmp_path / "archive")
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "logtools.cli.main",
        "batch",
        str(archive),
        "--out",
        str(out),
        "--workers",
        "1",
        "--repeats",
        "2",
        "--no-discovery",
        "--no-views",
    ]
    proc = subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        deadline = time.monotonic() + 240
        while len(_manifest(out)) < 2 and time.monotonic() < deadline:
            assert proc.poll() is None, "the batch ended before it could be killed"
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    done_before = set(_manifest(out))
    assert 2 <= len(done_before) < N_LOGS, done_before
    _check_whole(out)
    assert not (out / "index.html").exists()  # the report comes at the end

    summary = run_batch(archive, out, options=FAST, workers=1)
    assert set(summary.skipped) == done_before
    assert set(summary.analysed) == set(_manifest(out)) - done_before
    assert len(summary.analysed) + len(summary.skipped) == N_LOGS
    assert not list(out.rglob("*.partial*"))  # temporaries of the killed run removed
    _check_whole(out)

    # a fresh, uninterrupted run gives the same records
    fresh = tmp_path / "fresh"
    run_batch(archive, fresh, options=FAST, workers=1)
    for rel, entry in _manifest(fresh).items():
        a = json.loads((fresh / str(entry["record"])).read_text())
        b = json.loads((out / str(_manifest(out)[rel]["record"])).read_text())
        assert a == b, rel

    # touch one log (same bytes), rewrite another with new content: only that one is redone
    touched, changed = archive / "truckA" / "a00.mcap", archive / "truckA" / "a01.mcap"
    os.utime(touched, (time.time() + 100, time.time() + 100))
    sim_log(changed, seed=99, day=1)
    again = run_batch(archive, out, options=FAST, workers=1)
    assert again.analysed == ["truckA/a01.mcap"]
    assert len(again.skipped) == N_LOGS - 1
