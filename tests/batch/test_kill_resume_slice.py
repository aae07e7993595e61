"""A small slice of ``bench/batch_kill_resume.py``: a batch killed twice at random moments and
resumed ends with the records of an uninterrupted run (none lost, none twice, all whole), and
no worker outlives a kill."""

from __future__ import annotations

import random
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_killed_and_resumed_batch_equals_an_uninterrupted_one() -> None:
    seed = random.randrange(10**6)
    cmd = [sys.executable, str(ROOT / "bench" / "batch_kill_resume.py"), "--logs", "24"]
    cmd += ["--good", "2", "--kills", "2", "--seed", str(seed)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, f"seed {seed}\n{proc.stdout[-3000:]}\n{proc.stderr[-2000:]}"
    assert '"lost": 0' in proc.stdout
