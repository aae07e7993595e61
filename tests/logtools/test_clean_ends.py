"""Clean ends (issue 34): a full stdout (/dev/full), a closed stdout and a broken pipe end with
one message and exit 2 (quietly on the broken pipe); an ASCII or latin-1 stdout gets ASCII
spellings and escapes, never UnicodeEncodeError; no text report shows NaN as a number."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from logtools.cli.streams import ascii_spelling
from logtools.safe_text import no_nan

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "sample_logs" / "tt_mixed.csv"
SQUARE = REPO.parent / "shared" / "realworld_drive" / "optiodom" / "square" / "231220200029"
LOGCAL = [sys.executable, "-m", "logtools.cli.main"]


def _run(args: list[str], **kw: object) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run([*LOGCAL, *args], capture_output=True, check=False, timeout=300, **kw)  # type: ignore[call-overload, no-any-return]


def _one_clean_line(stderr: bytes) -> str:
    text = stderr.decode("utf-8", "replace")
    assert "Traceback" not in text
    assert "internal error" not in text
    assert "Exception ignored" not in text
    assert text.count("\n") == 1, text
    return text


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_full_stdout_is_one_message_and_exit_2() -> None:
    with open("/dev/full", "wb") as full:
        proc = subprocess.run(
            [*LOGCAL, "info", str(SAMPLE)],
            stdout=full,
            stderr=subprocess.PIPE,
            check=False,
            timeout=300,
        )
    assert proc.returncode == 2
    text = _one_clean_line(proc.stderr)
    assert "cannot write to standard output: No space left on device" in text


def test_closed_stdout_is_one_message_and_exit_2() -> None:
    proc = subprocess.run(
        [*LOGCAL, "info", str(SAMPLE)],
        stderr=subprocess.PIPE,
        preexec_fn=lambda: os.close(1),
        check=False,
        timeout=300,
    )
    assert proc.returncode == 2
    assert "standard output is closed" in _one_clean_line(proc.stderr)


def test_broken_pipe_ends_quietly_with_exit_2() -> None:
    with subprocess.Popen(
        [*LOGCAL, "info", *[str(SAMPLE)] * 80],  # ~80 KB: more than a pipe's 64 KiB buffer
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    ) as proc:
        assert proc.stdout is not None
        assert proc.stderr is not None
        proc.stdout.read(5)
        proc.stdout.close()
        err = proc.stderr.read()
        assert proc.wait(timeout=300) == 2
    assert err == b""


@pytest.mark.parametrize("encoding", ["ascii", "latin-1"])
def test_narrow_stdout_shows_hostile_names_escaped(tmp_path: Path, encoding: str) -> None:
    name = os.fsdecode(b"run_\xff\xe9_\xc2\xb1.csv")  # undecodable bytes, then a real "±"
    log = tmp_path / name
    shutil.copy(SAMPLE, log)
    env = {**os.environ, "PYTHONIOENCODING": encoding, "LC_ALL": "C"}
    proc = _run(["info", str(log)], env=env)
    assert proc.returncode == 0, proc.stderr
    first = proc.stdout.decode(encoding).splitlines()[0]
    assert first.endswith(
        "run_\\xff\\xe9_+/-.csv" if encoding == "ascii" else "run_\\xff\\xe9_±.csv"
    )


def test_ascii_spellings() -> None:
    assert ascii_spelling("1.25 ± 0.01 m, 3 × 4, 20 °") == "1.25 +/- 0.01 m, 3 x 4, 20  deg"
    assert ascii_spelling("é→ü\U0001f600") == "\\xe9->\\xfc\\U0001f600"
    assert ascii_spelling("±é", "latin-1") == "±é"


def test_no_nan_in_text() -> None:
    assert no_nan("residual nan rad, -inf m, +Infinity, 1.5") == "residual n/a rad, n/a m, n/a, 1.5"
    assert (
        no_nan("nanoseconds, info, banana, inflow, x.nan")
        == "nanoseconds, info, banana, inflow, x.nan"
    )


@pytest.mark.skipif(not SQUARE.is_dir(), reason="the OptiOdom data set is not here")
def test_a_ten_year_time_jump_prints_no_nan(tmp_path: Path) -> None:
    shutil.copy(SQUARE / "231220200029_metadata.csv", tmp_path)
    rows = (SQUARE / "231220200029_run-01.csv").read_text().splitlines()
    jump = 10 * 365.25 * 86400
    for i in range(len(rows) // 2, len(rows)):
        t, rest = rows[i].split(",", 1)
        rows[i] = f"{float(t) + jump!r},{rest}"
    log = tmp_path / "231220200029_run-01.csv"
    log.write_text("\n".join(rows) + "\n")
    proc = _run(["analyze", str(log), "--no-discovery", "--repeats", "2"])
    text = proc.stdout.decode() + proc.stderr.decode()
    assert proc.returncode in (0, 2), text
    assert "Traceback" not in text
    assert no_nan(text) == text, text
    assert "()" not in text
