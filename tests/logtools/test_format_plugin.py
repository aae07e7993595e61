"""A log format added as a plugin, touching no shared file: a JSON-lines export registered with
``register_format`` is read by ``read_log``, found in folders, shown by ``info`` and analysed."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl
import pytest

from logtools.cli.main import main
from logtools.readers import CSV_TOPIC, LogData, TopicInfo, read_log
from logtools.readers import formats as registry
from logtools.readers.format_reader import FormatReader, ReadRequest
from logtools.runs import expand_runs

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.csv"


def _read_jsonl(name: str, req: ReadRequest) -> LogData:
    frame = pl.read_ndjson(name)
    frame = frame.with_columns((pl.col("t") * 1e9).round().cast(pl.Int64).alias("t_ns")).drop("t")
    t = frame["t_ns"]
    info = TopicInfo(CSV_TOPIC, "", "jsonl", "jsonl", frame.height, int(t.min()), int(t.max()))
    return LogData(name, {CSV_TOPIC: frame}, {CSV_TOPIC: info}, {}, [])


JSONL = FormatReader(
    "jsonl",
    "JSON lines (one object per sample, time t in s)",
    (".jsonl",),
    lambda path, head: path.suffix == ".jsonl" and head.lstrip().startswith(b"{"),
    _read_jsonl,
)


@pytest.fixture
def jsonl_format(monkeypatch: pytest.MonkeyPatch):  # type: ignore[no-untyped-def]
    monkeypatch.setattr(registry, "_REGISTRY", list(registry.formats()))
    registry.register_format(JSONL, first=True)
    return JSONL


def _write(tmp_path: Path) -> Path:
    rows = pl.read_csv(SAMPLE).head(2000).to_dicts()
    out = tmp_path / "drive.jsonl"
    out.write_text("\n".join(json.dumps(r) for r in rows) + "\n")
    return out


@pytest.mark.usefixtures("jsonl_format")
def test_a_registered_format_is_read_walked_shown_and_analysed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write(tmp_path)
    data = read_log(log)
    assert data.topics[CSV_TOPIC].height == 2000
    assert ".jsonl" in registry.log_suffixes()
    assert expand_runs([tmp_path]) == [log]
    assert main(["info", str(log)]) == 0
    assert "psi" in capsys.readouterr().out
    assert main(["analyze", str(log), "--json", "--no-discovery", "--repeats", "1"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "tractor_trailer"
    assert doc["estimate"]["L1"]["value"] == pytest.approx(1.25, abs=0.1)


def test_without_registration_the_format_is_refused(tmp_path: Path) -> None:
    from logtools.errors import LogcalInputError

    log = _write(tmp_path)
    with pytest.raises(LogcalInputError, match="starts with the bytes"):
        read_log(log)
    assert ".jsonl" not in registry.log_suffixes()
