"""``logcal batch --start/--end`` (and the ``logcal.toml`` keys ``start``/``end``): every log is
cropped as ``logcal analyze --start/--end`` crops it, the bounds are recorded per log and in the
manifest, a batch resumed with other bounds redoes its logs, and bad bounds are one clear
error."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from batch_archive import FAST, sim_log

from logtools.batch.runner import load_manifest, read_records, run_batch
from logtools.cli.main import main

_SPAN = dataclasses.replace(FAST, start_s=5.0, end_s=25.0)


@pytest.fixture(scope="module")
def archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("span_archive")
    for i in range(2):
        sim_log(root / "truck" / f"s{i}.mcap", seed=40 + i, day=i, duration_s=40.0)
    return root


@pytest.fixture(scope="module")
def cropped(archive: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("span_out")
    summary = run_batch(archive, out, options=_SPAN, report=False)
    assert len(summary.analysed) == 2
    assert summary.failed == []
    return out


def test_records_equal_analyze_with_the_same_bounds(
    archive: Path, cropped: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    records = read_records(cropped)
    assert len(records) == 2
    for record in records:
        assert record["span"] == {"start_s": 5.0, "end_s": 25.0}
        path = str(archive / record["log"])
        assert (
            main(
                [
                    "analyze",
                    path,
                    "--start",
                    "5",
                    "--end",
                    "25",
                    "--json",
                    "--repeats",
                    str(FAST.repeats),
                    "--no-discovery",
                ]
            )
            == 0
        )
        alone = json.loads(capsys.readouterr().out)
        assert record["result"] == alone
        assert any("cropped to 5.000 s .. 25.000 s" in w for w in alone["warnings"])
    manifest = load_manifest(cropped)
    assert {e["log"]: e["span"]["end_s"] for e in manifest.values()} == {
        "truck/s0.mcap": 25.0,
        "truck/s1.mcap": 25.0,
    }


def test_other_bounds_redo_the_logs(archive: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    first = run_batch(archive, out, options=_SPAN, report=False)
    assert len(first.analysed) == 2
    again = run_batch(archive, out, options=_SPAN, report=False)
    assert (again.analysed, len(again.skipped)) == ([], 2)
    before = {r["log"]: r["result"] for r in read_records(out)}
    wider = run_batch(archive, out, options=dataclasses.replace(_SPAN, end_s=35.0), report=False)
    assert len(wider.analysed) == 2
    after = read_records(out)
    assert all(r["span"]["end_s"] == 35.0 for r in after)
    assert all(r["result"] != before[r["log"]] for r in after)
    whole = run_batch(archive, out, options=FAST, report=False)  # no bounds: redone too
    assert len(whole.analysed) == 2
    assert all(r["span"] == {"start_s": None, "end_s": None} for r in read_records(out))


def test_settings_keys_and_the_command_line_wins(archive: Path, tmp_path: Path) -> None:
    local = tmp_path / "archive"
    (local / "truck").mkdir(parents=True)
    for p in (archive / "truck").iterdir():
        (local / "truck" / p.name).write_bytes(p.read_bytes())
    (local / "truck" / "logcal.toml").write_text("start = 5\nend = 25\n")
    by_settings = tmp_path / "by_settings"
    run_batch(local, by_settings, options=FAST, report=False)
    cropped = run_batch(archive, tmp_path / "by_options", options=_SPAN, report=False)
    assert cropped.failed == []
    expected = {r["log"]: r["result"]["estimate"] for r in read_records(tmp_path / "by_options")}
    records = read_records(by_settings)
    assert {r["log"]: r["result"]["estimate"] for r in records} == expected
    assert all(r["span"] == {"start_s": 5.0, "end_s": 25.0} for r in records)
    run_batch(local, by_settings, options=dataclasses.replace(FAST, end_s=35.0), report=False)
    assert all(r["span"] == {"start_s": 5.0, "end_s": 35.0} for r in read_records(by_settings))


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--start", "10", "--end", "5"], "--end 5 s is not after --start 10 s"),
        (["--start", "10", "--end", "10"], "--end 10 s is not after --start 10 s"),
        (["--start", "-1"], "--start"),
        (["--end", "-3"], "--end"),
    ],
)
def test_bad_bounds_exit_2(
    archive: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], said: str
) -> None:
    out = tmp_path / "out"
    assert main(["batch", str(archive), "--out", str(out), "--no-views", *args]) == 2
    err = capsys.readouterr().err
    assert said in err
    assert "Traceback" not in err
    assert not (out / "manifest.json").exists()


@pytest.mark.parametrize(
    ("toml", "said"),
    [
        ("start = 10\nend = 5\n", "[end] is 5 s, not after start = 10 s"),
        ("start = -2\n", "[start] is -2; expected seconds >= 0"),
        ('end = "soon"\n', "[end] is 'soon'; expected seconds >= 0"),
    ],
)
def test_bad_settings_bounds_fail_their_logs(
    archive: Path, tmp_path: Path, toml: str, said: str
) -> None:
    local = tmp_path / "archive"
    (local / "truck").mkdir(parents=True)
    src = archive / "truck" / "s0.mcap"
    (local / "truck" / "s0.mcap").write_bytes(src.read_bytes())
    (local / "truck" / "logcal.toml").write_text(toml)
    summary = run_batch(local, tmp_path / "out", options=FAST, report=False)
    ((rel, message),) = summary.failed
    assert rel == "truck/s0.mcap"
    assert "logcal.toml" in message
    assert said in message
