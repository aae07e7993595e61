"""Nothing lost (issue 34): records are never deleted by omission, --prune only when the archive
is read whole and not empty, a full disk on --out is one message and leaves whole files that a
rerun resumes from, and every write is flushed then renamed (old or new state, never a mix)."""

from __future__ import annotations

import errno
import json
import os
import shutil
from pathlib import Path

import pytest
from batch_archive import FAST

import logtools.batch.runner as runner
from logtools.batch.archive import LogJob
from logtools.batch.runner import load_manifest, prune_refusal, run_batch
from logtools.cli.main import launch
from logtools.outputs import write_atomically

CORRUPT = b"\x89MCAP0\r\n" + bytes(range(256)) * 4


def _archive(root: Path, n: int = 3) -> Path:
    """``n`` corrupt MCAPs: each fails fast, and a failed log is a record like any other."""
    root.mkdir(parents=True)
    for i in range(n):
        (root / f"log{i}.mcap").write_bytes(CORRUPT + bytes([i]))
    return root


def _records(out: Path) -> dict[str, dict[str, object]]:
    return {str(e["log"]): e for e in load_manifest(out).values()}


def test_empty_archive_keeps_every_record(tmp_path: Path) -> None:
    archive, out = _archive(tmp_path / "a"), tmp_path / "out"
    run_batch(archive, out, options=FAST, report=False)
    before = {p.name: p.read_bytes() for p in (out / "logs").iterdir()}
    assert len(before) == 3
    empty = tmp_path / "empty"
    empty.mkdir()
    summary = run_batch(empty, out, options=FAST)
    assert "log gone from the archive; kept" in (out / "index.html").read_text()
    assert summary.logs == 0
    assert summary.gone == ["log0.mcap", "log1.mcap", "log2.mcap"]
    assert {p.name: p.read_bytes() for p in (out / "logs").iterdir()} == before
    assert all(e["gone"] is True for e in _records(out).values())
    pruned = run_batch(empty, out, options=FAST, report=False, prune=True)
    assert pruned.pruned == []
    assert pruned.prune_refused is not None
    assert "no log" in pruned.prune_refused
    assert len(list((out / "logs").iterdir())) == 3


def test_records_of_a_removed_log_are_kept_until_pruned(tmp_path: Path) -> None:
    archive, out = _archive(tmp_path / "a"), tmp_path / "out"
    run_batch(archive, out, options=FAST, report=False)
    moved = tmp_path / "log1.mcap"
    shutil.move(archive / "log1.mcap", moved)
    kept = run_batch(archive, out, options=FAST, report=False)
    assert kept.gone == ["log1.mcap"]
    assert kept.analysed == []
    assert sorted(kept.skipped) == ["log0.mcap", "log2.mcap"]
    assert "log1.mcap" not in [name for name, _ in kept.failed]
    assert len(list((out / "logs").iterdir())) == 3
    assert {r["log"]: r["gone"] for r in runner.read_records(out)}["log1.mcap"] is True
    shutil.move(moved, archive / "log1.mcap")  # back: not gone, and not redone
    back = run_batch(archive, out, options=FAST, report=False)
    assert back.gone == []
    assert back.analysed == []
    assert "gone" not in _records(out)["log1.mcap"]
    os.unlink(archive / "log1.mcap")
    pruned = run_batch(archive, out, options=FAST, report=False, prune=True)
    assert pruned.pruned == ["log1.mcap"]
    assert pruned.gone == []
    assert set(_records(out)) == {"log0.mcap", "log2.mcap"}
    assert len(list((out / "logs").iterdir())) == 2


def test_an_unlisted_folder_refuses_prune() -> None:
    seen = LogJob("x.mcap", "/a/x.mcap", "x.mcap-0123456789", "h", None)
    unlisted = LogJob(
        "sub", "/a/sub", "sub-0123456789", "", None, entry_error="sub: cannot list this folder"
    )
    assert prune_refusal([seen]) is None
    assert prune_refusal([]) is not None
    refusal = prune_refusal([seen, unlisted])
    assert refusal is not None
    assert "sub" in refusal


def test_cli_says_records_are_kept(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    archive, out = _archive(tmp_path / "a", n=1), tmp_path / "out"
    run_batch(archive, out, options=FAST, report=False)
    empty = tmp_path / "empty"
    empty.mkdir()
    code = launch(["batch", str(empty), "--out", str(out), "--no-views", "--no-discovery"])
    assert code == 0
    err = capsys.readouterr().err
    assert "1 record(s) kept whose log is gone" in err
    assert "--prune" in err
    assert len(list((out / "logs").iterdir())) == 1


def test_full_disk_on_out_is_one_message_and_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    archive, out = _archive(tmp_path / "a", n=4), tmp_path / "out"
    real = runner.write_atomic
    calls = {"n": 0}

    def full_after_two(path: Path, data: bytes) -> None:
        if path.parent.name == "logs":
            calls["n"] += 1
            if calls["n"] > 2:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        real(path, data)

    monkeypatch.setattr(runner, "write_atomic", full_after_two)
    args = ["--no-views", "--no-discovery", "--repeats", "2", "--workers", "1"]
    code = launch(["batch", str(archive), "--out", str(out), *args])
    err = capsys.readouterr().err
    assert code == 2
    assert "No space left on device" in err
    assert "a rerun resumes" in err
    assert "internal error" not in err
    assert "Traceback" not in err
    assert len(_records(out)) == 2
    for p in out.rglob("*.json"):
        json.loads(p.read_bytes())
    monkeypatch.setattr(runner, "write_atomic", real)
    summary = run_batch(archive, out, options=FAST, report=False)
    assert len(summary.skipped) == 2
    assert len(summary.analysed) == 2
    assert len(_records(out)) == 4


def test_a_failed_write_leaves_the_old_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "manifest.json"
    target.write_bytes(b"old")

    def no_space(tmp: Path) -> None:
        tmp.write_bytes(b"half")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OSError, match="No space"):
        write_atomically(target, no_space)
    assert target.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["manifest.json"]
    synced: list[str] = []
    real_fsync = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: synced.append(os.readlink(f"/proc/self/fd/{fd}")))
    write_atomically(target, lambda tmp: tmp.write_bytes(b"new"))
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert target.read_bytes() == b"new"
    assert any(".partial" in s for s in synced)
    assert str(tmp_path) in synced


def test_a_torn_journal_line_does_not_swallow_the_next(tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "logs").mkdir(parents=True)
    (out / runner.JOURNAL).write_bytes(b'{"id": "torn-0123456789", "ent')
    journal = runner._Journal(out)
    entry = {"id": "log0.mcap-0123456789", "log": "log0.mcap", "views": {}}
    journal.append({"id": entry["id"], "entry": entry})
    journal.close()
    assert set(load_manifest(out)) == {"log0.mcap-0123456789"}
