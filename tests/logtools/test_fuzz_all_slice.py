"""A small random slice of ``bench/fuzz_all.py``: one hostile input of every class (readers,
URDFs, channel maps, log metadata, batch archives and settings, HTTP requests to ``serve``), each
in a worker under a memory cap and time bounds, must end in data or one clean refusal."""

from __future__ import annotations

import random
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_one_input_of_every_class(tmp_path: Path) -> None:
    seed = random.randrange(10**6)
    sys.path.insert(0, str(ROOT / "bench"))
    from fuzz_all import CLASSES

    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "bench" / "fuzz_all.py"),
            "--inputs",
            str(len(CLASSES)),
            "--seed",
            str(seed),
            "--save",
            str(tmp_path / "failures"),
            "--wall-s",
            "300",
        ],
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    replay = f"python bench/fuzz_all.py --inputs {len(CLASSES)} --seed {seed}"
    assert proc.returncode == 0, f"{replay}\n{proc.stdout[-3000:]}\n{proc.stderr[-2000:]}"
    total = next(ln for ln in proc.stdout.splitlines() if ln.startswith("TOTAL"))
    assert int(total.split()[1]) == len(CLASSES), total
