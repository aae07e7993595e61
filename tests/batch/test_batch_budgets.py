"""Per-log budgets of ``logcal batch`` (``--log-memory``, ``--log-timeout``): a log that hangs
(in Python, or where the alarm cannot reach it) or allocates past its budget is recorded as
failed, naming the budget; the other logs of the archive are analysed; the batch exits 0."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl
import pytest
from budget_readers import HOG_GIB, install

from logtools.batch import engines
from logtools.batch.budgets import Budgets, out_of_memory
from logtools.batch.engines import ray_task_options
from logtools.cli.main import main
from logtools.errors import LogcalInputError
from logtools.readers import formats as registry

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.csv"
FAST = ["--repeats", "2", "--no-discovery", "--no-views"]


@pytest.fixture
def misbehaving_readers(monkeypatch: pytest.MonkeyPatch) -> None:
    """The readers of budget_readers, here and in every spawned worker."""
    monkeypatch.setattr(registry, "_REGISTRY", list(registry.formats()))
    install()
    monkeypatch.setattr(engines, "_WORKER_SETUP", "budget_readers:install")


def _archive(root: Path, bad: tuple[str, ...], good: int = 3) -> Path:
    csv = pl.read_csv(SAMPLE).head(1500).write_csv()
    root.mkdir()
    for i in range(good):
        (root / f"good{i}.csv").write_text(csv)
    for suffix in bad:
        (root / f"bad{suffix}").write_text(csv)
    return root


def _entries(out: Path) -> dict[str, dict[str, object]]:
    manifest = json.loads((out / "manifest.json").read_text())
    return {e["log"]: e for e in manifest["logs"].values()}


BUDGET_S = 30
"""The per-log time budget: the hung and stuck readers never end, so they meet it whatever the
machine's speed; good logs take a few seconds on an idle machine and stay well inside it on a
loaded one (6 s was missed by a good log with a second test suite running beside it)."""


@pytest.mark.usefixtures("misbehaving_readers")
def test_hung_stuck_and_hungry_logs_fail_by_their_budget_and_the_rest_is_analysed(
    tmp_path: Path,
) -> None:
    archive = _archive(tmp_path / "a", (".hang", ".stuck", ".hog"))
    out = tmp_path / "out"
    code = main(
        [
            "batch",
            str(archive),
            "--out",
            str(out),
            "--workers",
            "2",
            *FAST,
            "--log-timeout",
            str(BUDGET_S),
            "--log-memory",
            "3",
        ]
    )
    assert code == 0
    logs = _entries(out)
    assert [logs[f"good{i}.csv"]["status"] for i in range(3)] == ["ok"] * 3
    assert all(logs[f"bad{s}"]["status"] == "failed" for s in (".hang", ".stuck", ".hog"))
    assert (
        logs["bad.hang"]["error"]
        == f"bad.hang: took longer than the per-log time budget of {BUDGET_S} s (--log-timeout)"
    )
    stuck = str(logs["bad.stuck"]["error"])
    assert f"per-log time budget of {BUDGET_S} s (--log-timeout)" in stuck
    assert "stopped" in stuck
    assert (
        logs["bad.hog"]["error"]
        == "bad.hog: exceeded the per-log memory budget of 3 GiB (--log-memory)"
    )
    # the stuck worker's stack, dumped by the hard stop, is the record's detail
    record = json.loads((out / "logs" / f"{logs['bad.stuck']['id']}.json").read_text())
    assert "_stuck" in record["detail"]


@pytest.mark.usefixtures("misbehaving_readers")
def test_without_budgets_the_same_readers_are_not_stopped(tmp_path: Path) -> None:
    """The control: with no memory budget the hungry reader's untouched HOG_GIB GiB are
    granted and its log is analysed (the failure above is the budget's doing)."""
    assert HOG_GIB < 20
    archive = _archive(tmp_path / "a", (".hog",), good=0)
    out = tmp_path / "out"
    assert (
        main(
            ["batch", str(archive), "--out", str(out), "--workers", "1", *FAST, "--log-memory", "0"]
        )
        == 0
    )
    assert _entries(out)["bad.hog"]["status"] == "ok"


@pytest.mark.parametrize(
    ("flag", "value"),
    [
        ("--log-memory", "-1"),
        ("--log-timeout", "abc"),
        ("--log-timeout", "-5"),
        ("--log-memory", "nan"),
        ("--log-timeout", "inf"),
    ],
)
def test_bad_budgets_exit_2(
    tmp_path: Path, flag: str, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    archive = _archive(tmp_path / "a", (), good=1)
    assert main(["batch", str(archive), "--out", str(tmp_path / "out"), flag, value]) == 2
    assert flag in capsys.readouterr().err
    assert not (tmp_path / "out" / "manifest.json").exists()


def test_budgets_from_flags() -> None:
    b = Budgets.from_flags(None, 3600.0, workers=2)
    assert b.memory_default
    assert b.memory_gib is not None
    assert 6.0 <= b.memory_gib <= 8.0
    assert b.hard_stop_s == 3660.0
    none = Budgets.from_flags(0.0, 0.0, workers=2)
    assert none.memory_bytes is None
    assert none.timeout_s is None
    assert none.hard_stop_s is None
    assert Budgets.from_flags(0.5, 1.0, workers=2).hard_stop_s == 3.0
    with pytest.raises(LogcalInputError, match="--log-memory"):
        Budgets(memory_gib=-1.0)


def test_out_of_memory_errors_are_recognised() -> None:
    import errno
    import sqlite3

    assert out_of_memory(MemoryError())
    assert out_of_memory(OSError(errno.ENOMEM, "Cannot allocate memory"))
    assert out_of_memory(sqlite3.OperationalError("out of memory"))
    outer = LogcalInputError("cannot read x.mcap")
    outer.__cause__ = MemoryError()
    assert out_of_memory(outer)
    assert not out_of_memory(ValueError("bad column"))


def test_ray_task_requests_the_memory_budget() -> None:
    gib = 2**30
    explicit = Budgets(memory_gib=2.0, timeout_s=10.0)
    assert ray_task_options(explicit, [16.0 * gib])["memory"] == 2 * gib
    assert ray_task_options(explicit, [16.0 * gib])["num_cpus"] == 1
    # a default share larger than any node: lowered to the largest node
    default = Budgets(memory_gib=8.0, memory_default=True)
    assert ray_task_options(default, [4.0 * gib, 6.0 * gib])["memory"] == 6 * gib
    with pytest.raises(LogcalInputError, match="--log-memory 32"):
        ray_task_options(Budgets(memory_gib=32.0), [16.0 * gib])
    assert "memory" not in ray_task_options(Budgets(memory_gib=None), [16.0 * gib])
