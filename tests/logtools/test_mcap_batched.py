"""A large MCAP file decoded a batch of chunks at a time reads exactly as when read whole."""

from __future__ import annotations

from pathlib import Path

import pytest
from polars.testing import assert_frame_equal

from logtools.readers import LogData, builtin_formats, mcap_reader, read_log

ROOT = Path(__file__).resolve().parents[2]
LOGS = sorted((ROOT / "sample_logs").glob("*.mcap")) + sorted(
    (ROOT.parent / "shared" / "realworld_mcap").glob("*.mcap")
)


def _read(path: Path, batch_bytes: int, monkeypatch: pytest.MonkeyPatch, **kw: object) -> LogData:
    """``read_log`` with batches of ``batch_bytes`` for a file of any size (2**62: whole)."""
    monkeypatch.setattr(mcap_reader, "BATCH_BYTES", batch_bytes)
    monkeypatch.setattr(builtin_formats, "_BATCHED_MIN_BYTES", 0)
    return read_log(path, **kw)  # type: ignore[arg-type]


def _same(a: LogData, b: LogData) -> None:
    assert a.topics.keys() == b.topics.keys()
    for topic in a.topics:
        assert_frame_equal(a.topics[topic], b.topics[topic])
    assert a.info == b.info
    assert [(p.kind, p.topic, p.count, p.message) for p in a.problems] == [
        (p.kind, p.topic, p.count, p.message) for p in b.problems
    ]
    assert a.metadata == b.metadata


@pytest.fixture
def batched(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each read went batch by batch."""
    used: list[bool] = []
    real = mcap_reader.read_mcap_batched

    def spy(*args: object) -> LogData | None:
        out = real(*args)  # type: ignore[arg-type]
        used.append(out is not None)
        return out

    monkeypatch.setattr(mcap_reader, "read_mcap_batched", spy)
    return used


@pytest.mark.parametrize("path", LOGS, ids=lambda p: p.name)
def test_one_chunk_per_batch_reads_as_whole(
    path: Path, monkeypatch: pytest.MonkeyPatch, batched: list[bool]
) -> None:
    whole = _read(path, 2**62, monkeypatch)
    assert batched == [False]
    _same(_read(path, 1, monkeypatch), whole)


def test_the_sample_logs_do_go_batch_by_batch(
    monkeypatch: pytest.MonkeyPatch, batched: list[bool]
) -> None:
    for path in sorted((ROOT / "sample_logs").glob("tt_*.mcap")):
        _read(path, 1, monkeypatch)
    assert batched  # written by logcal: summary, statistics, chunk index
    assert all(batched)


def test_topics_argument(monkeypatch: pytest.MonkeyPatch, batched: list[bool]) -> None:
    path = ROOT / "sample_logs" / "tt_mixed.mcap"
    kw = {"topics": ["/odom", "/hitch/angle"]}
    _same(_read(path, 1, monkeypatch, **kw), _read(path, 2**62, monkeypatch, **kw))
    assert batched[0]


@pytest.mark.parametrize("cut", [0.5, 0.9, 0.999])
def test_a_damaged_file_is_read_whole(
    cut: float, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, batched: list[bool]
) -> None:
    data = (ROOT / "sample_logs" / "tt_mixed.mcap").read_bytes()
    path = tmp_path / "cut.mcap"
    path.write_bytes(data[: int(len(data) * cut)])  # no footer, no summary: not batchable
    _same(_read(path, 1, monkeypatch), _read(path, 2**62, monkeypatch))
    assert not any(batched)


def test_a_corrupt_chunk_sends_the_file_back_to_the_whole_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, batched: list[bool]
) -> None:
    data = bytearray((ROOT / "sample_logs" / "tt_mixed.mcap").read_bytes())
    summary, _ = mcap_reader.read_summary(bytes(data))
    chunk = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)[1]
    body = chunk.chunk_start_offset + chunk.chunk_length - 64  # inside the compressed records
    data[body : body + 16] = b"\x00" * 16
    path = tmp_path / "corrupt.mcap"
    path.write_bytes(bytes(data))
    batched_read = _read(path, 1, monkeypatch)
    assert batched == [False]  # the batch with that chunk found the damage: read whole
    _same(batched_read, _read(path, 2**62, monkeypatch))
    assert any(
        p.kind.name in ("CHUNK_ERROR", "LOST_CHUNK", "LOST_MESSAGES") for p in batched_read.problems
    )


def test_a_column_filter_reads_alike(monkeypatch: pytest.MonkeyPatch, batched: list[bool]) -> None:
    path = ROOT / "sample_logs" / "tt_mixed_ros2.mcap"

    def keep(topic: str, column: str) -> bool:
        return ".covariance." not in column and not (topic == "/pose" and column.endswith("z"))

    lean = _read(path, 1, monkeypatch, keep=keep)
    _same(lean, _read(path, 2**62, monkeypatch, keep=keep))
    assert batched[0]
    assert not any(".covariance." in c for f in lean.topics.values() for c in f.columns)


def test_two_files_appended_are_read_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, batched: list[bool]
) -> None:
    """The last footer then belongs to the second file: its summary offset points into the
    first, where the summary read finds a footer; the whole read reports the concatenation."""
    data = (ROOT / "sample_logs" / "tt_mixed.mcap").read_bytes()
    path = tmp_path / "twice.mcap"
    path.write_bytes(data + data)
    log = _read(path, 1, monkeypatch)
    assert batched == [False]
    assert any(p.kind.name == "CONCATENATED" for p in log.problems)
