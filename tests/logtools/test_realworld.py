"""Every real rosbag2 MCAP in shared/realworld_mcap is read, in agreement with the stock reader."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from logtools.channel_map import resolve_signals
from logtools.cli.main import main
from logtools.errors import NoDriveSignalsError
from logtools.readers import read_log
from logtools.robot import infer_robot

REALWORLD_DIR = Path(__file__).parents[2] / ".." / "shared" / "realworld_mcap"
FILES = sorted(REALWORLD_DIR.glob("*.mcap"))
needs_files = pytest.mark.skipif(not FILES, reason=f"no real-world MCAP files in {REALWORLD_DIR}")


def _stock(path: Path) -> tuple[dict[str, int], dict[str, list[tuple[int, object]]]]:
    """Summary counts per topic and decoded messages per topic, from the mcap library itself."""
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        assert summary.statistics is not None
        counts = {
            ch.topic: summary.statistics.channel_message_counts.get(cid, 0)
            for cid, ch in summary.channels.items()
        }
        decoded: dict[str, list[tuple[int, object]]] = {}
        for _, channel, message, obj in reader.iter_decoded_messages():
            decoded.setdefault(channel.topic, []).append((message.log_time, obj))
    return counts, decoded


@needs_files
@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_read_matches_stock_reader(path):
    log = read_log(path)
    counts, decoded = _stock(path)
    assert log.problems == []
    assert {t: i.message_count for t, i in log.info.items()} == counts
    for topic, messages in decoded.items():
        frame = log.topics[topic]
        assert frame["t_ns"].to_list() == sorted(t for t, _ in messages)
        ordered = [obj for _, obj in sorted(messages, key=lambda m: m[0])]
        for field in ordered[0].__slots__:
            value = getattr(ordered[0], field)
            if isinstance(value, (bool, int, float, str)):
                assert frame[field].to_list() == [getattr(o, field) for o in ordered], field


@needs_files
@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_no_drive_signals_said_clearly(path):
    log = read_log(path)
    res = resolve_signals(log)
    assert res.signals == {}
    with pytest.raises(NoDriveSignalsError) as info:
        infer_robot(log, res)
    assert all(topic in str(info.value) for topic in log.topic_names())


@needs_files
@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_cli_info_lists_topics(path, capsys):
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    log = read_log(path)
    for topic, info in log.info.items():
        assert f"  {topic}  {info.schema_name}" in text
    assert "robot: unknown" in text
    assert main(["info", "--json", str(path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [t["topic"] for t in doc["topics"]] == log.topic_names()
    assert doc["robot"] is None
