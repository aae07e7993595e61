"""A corruption corpus built from a sample log, each case with its defined outcome:
data with a named problem, or one clean LogcalInputError. Deterministic and fast (the scan is
exercised; only one topic is decoded), plus a small hypothesis slice for the readers."""

from __future__ import annotations

import io
import os
import struct
import time
from pathlib import Path

import lz4.frame
import pytest
import zstandard
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.writer import CompressionType, Writer

from logtools.errors import LogcalInputError, NotAnMcapError, TimestampError
from logtools.readers import LogData, ProblemKind, read_log
from logtools.readers.mcap_scan import MAGIC, scan_mcap

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_logs" / "tt_mixed_ros2.mcap"  # ROS 2 (cdr), zstd, 7 chunks, summary
TOPIC = ["/hitch/angle"]
N_MESSAGES = 22415


@pytest.fixture(scope="module")
def sample() -> bytes:
    return SAMPLE.read_bytes()


@pytest.fixture(scope="module")
def layout(sample):
    scan = scan_mcap(sample)
    chunks = sorted(scan.chunk_indexes, key=lambda c: c.chunk_start_offset)
    footer = len(sample) - len(MAGIC) - 29
    (summary_start,) = struct.unpack_from("<Q", sample, footer + 9)
    return {"chunks": chunks, "footer": footer, "summary": summary_start}


def _read(tmp_path: Path, buf: bytes, suffix: str = ".mcap") -> LogData | LogcalInputError:
    path = tmp_path / f"case{suffix}"
    path.write_bytes(buf)
    try:
        return read_log(path, topics=TOPIC)
    except LogcalInputError as err:  # the defined failure; any other exception fails the test
        return err


def _kinds(log: LogData) -> set[str]:
    return {p.kind.value for p in log.problems}


def _count(log: LogData) -> int:
    return sum(i.message_count for i in log.info.values())


def test_truncation_at_many_offsets(tmp_path, sample):
    for k in range(1, 41):
        cut = len(sample) * k // 41
        out = _read(tmp_path, sample[:cut])
        if isinstance(out, LogcalInputError):
            assert str(out).startswith(str(tmp_path)), out
            continue
        assert _count(out) < N_MESSAGES
        assert _kinds(out) & {"truncated", "no_footer", "lost_messages", "lost_chunk"}, cut


@pytest.mark.parametrize(
    ("where", "expected", "complete"),
    [
        ("header", {"corrupt_bytes"}, True),
        ("chunk_body", {"lost_chunk", "lost_messages"}, False),
        ("chunk_crc", {"lost_chunk", "lost_messages"}, False),
        ("chunk_size", {"chunk_error", "lost_chunk", "lost_messages"}, False),
        ("summary", set(), True),  # a damaged summary is ignored; the data section is whole
        ("footer", set(), True),
    ],
)
def test_bit_flip(tmp_path, sample, layout, where, expected, complete):
    chunk = layout["chunks"][2].chunk_start_offset
    offset = {
        "header": 12,
        "chunk_body": chunk + 200,
        "chunk_crc": chunk + 9 + 24,
        "chunk_size": chunk + 9 + 16 + 3,
        "summary": layout["summary"] + 30,
        "footer": layout["footer"] + 12,
    }[where]
    buf = bytearray(sample)
    buf[offset] ^= 0x10
    out = _read(tmp_path, bytes(buf))
    assert isinstance(out, LogData)
    assert _kinds(out) == expected
    assert (_count(out) == N_MESSAGES) is complete


def test_out_of_order_chunks_are_sorted_and_said(tmp_path, sample, layout):
    c = [ci.chunk_start_offset for ci in layout["chunks"]]
    swapped = sample[: c[2]] + sample[c[3] : c[4]] + sample[c[2] : c[3]] + sample[c[4] :]
    out = _read(tmp_path, swapped)
    assert isinstance(out, LogData)
    assert _kinds(out) == {"unsorted"}
    assert _count(out) == N_MESSAGES
    assert out.topics["/hitch/angle"]["t_ns"].is_sorted()


def test_concatenated_files_name_the_second(tmp_path, sample):
    out = _read(tmp_path, sample + sample)
    assert isinstance(out, LogData)
    [p] = out.problems
    assert (p.kind, p.count) == (ProblemKind.CONCATENATED, len(sample))
    assert _count(out) == N_MESSAGES


def _record(opcode: int, body: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(body)) + body


def _one_chunk_file(compression: str, payload: bytes, declared: int) -> bytes:
    """Header + one chunk whose records are ``payload`` compressed, declaring ``declared``."""
    data = (
        zstandard.ZstdCompressor(level=19).compress(payload)
        if compression == "zstd"
        else (lz4.frame.compress(payload))
    )
    body = struct.pack("<QQQI", 0, 1, declared, 0) + struct.pack("<I", len(compression))
    body += compression.encode() + struct.pack("<Q", len(data)) + data
    header = _record(0x01, struct.pack("<I", 0) + struct.pack("<I", 0))
    return MAGIC + header + _record(0x06, body)


def _records() -> bytes:
    """Schema, channel and one message, as chunk content."""
    schema = struct.pack("<H", 1) + struct.pack("<I", 1) + b"s" + struct.pack("<I", 10)
    schema += b"jsonschema" + struct.pack("<I", 2) + b"{}"
    channel = struct.pack("<HH", 1, 1) + struct.pack("<I", 2) + b"/x" + struct.pack("<I", 4)
    channel += b"json" + struct.pack("<I", 0)
    message = struct.pack("<HIQQ", 1, 0, 5, 5) + b'{"a": 1}'
    return _record(0x03, schema) + _record(0x04, channel) + _record(0x05, message)


def test_zstd_bomb_is_refused_by_the_budget(tmp_path):
    bomb = _one_chunk_file("zstd", bytes(200 << 20), 200 << 20)
    assert len(bomb) < 10_000
    t0 = time.perf_counter()
    out = _read(tmp_path, bomb)
    assert isinstance(out, NotAnMcapError)
    assert "decompression budget" in str(out)
    assert time.perf_counter() - t0 < 2.0


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_chunk_larger_than_declared_is_lost_not_expanded(tmp_path, compression):
    payload = _records() + bytes(8 << 20)
    out = _read(tmp_path, _one_chunk_file(compression, payload, len(_records())))
    assert isinstance(out, NotAnMcapError)
    assert "more than the" in str(out)


@pytest.mark.parametrize("declared", [2**63, 2**64 - 1])
def test_huge_declared_chunk_size_is_a_problem_not_an_overflow(tmp_path, declared):
    out = _read(tmp_path, _one_chunk_file("zstd", _records(), declared))
    assert isinstance(out, NotAnMcapError)
    assert "declares" in str(out)


def test_well_formed_hand_made_chunk_reads(tmp_path):
    out = _read(tmp_path, _one_chunk_file("lz4", _records(), len(_records())))
    assert isinstance(out, LogData)
    assert _count(out) == 1


def test_reused_channel_id_is_named(tmp_path):
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE, use_chunking=False)
    w.start()
    sid = w.register_schema("s", "jsonschema", b"{}")
    a = w.register_channel("/aaaa", "json", sid)
    b = w.register_channel("/bbbb", "json", sid)
    for i in range(3):
        w.add_message(a, 10 + i, b'{"v": 1}', 10 + i)
        w.add_message(b, 20 + i, b'{"v": 2}', 20 + i)
    w.finish()
    raw = bytearray(buf.getvalue())
    at = raw.index(b"/bbbb") - 4 - 2 - 2  # channel id precedes schema id and topic length
    raw[at : at + 2] = struct.pack("<H", a)
    out = _read(tmp_path, bytes(raw))
    assert isinstance(out, LogData)
    dup = [p for p in out.problems if p.kind is ProblemKind.DUPLICATE_CHANNEL]
    assert dup
    assert "/aaaa" in dup[0].message
    assert "/bbbb" in dup[0].message


def test_not_a_regular_file_is_refused_without_reading(tmp_path):
    fifo = tmp_path / "pipe.mcap"
    os.mkfifo(fifo)
    for path in (fifo, Path("/dev/zero")):
        t0 = time.perf_counter()
        with pytest.raises(NotAnMcapError, match="not a regular file"):
            read_log(path)
        assert time.perf_counter() - t0 < 1.0


def test_csv_cut_row_epoch_time_and_impossible_time(tmp_path):
    cut = _read(tmp_path, b"t,v,omega\n0,1,0\n0.1,1,0\n0.2,1", ".csv")
    assert isinstance(cut, LogData)
    assert cut.topics["csv"].height == 2
    assert [(p.kind, p.count) for p in cut.problems] == [(ProblemKind.TRUNCATED, 1)]
    ms = _read(tmp_path, b"t,v\n1700000000000,1\n1700000000020,2\n", ".csv")
    assert isinstance(ms, LogData)
    assert [p.kind for p in ms.problems] == [ProblemKind.TIME_UNIT]
    assert ms.topics["csv"]["t_ns"].to_list() == [1_700_000_000 * 10**9, 1_700_000_000_020_000_000]
    huge = _read(tmp_path, b"t,v\n0,1\n1e300,2\n0.2,3\n", ".csv")
    assert isinstance(huge, TimestampError)
    assert "1e+300" in str(huge)


# ---------------------------------------------------------------- property slice


def _small_mcap(compression: CompressionType) -> bytes:
    buf = io.BytesIO()
    w = Writer(buf, compression=compression, chunk_size=512)
    w.start()
    sid = w.register_schema("s", "jsonschema", b"{}")
    ch = [w.register_channel(t, "json", sid) for t in ("/odom", "/hitch/angle")]
    for i in range(60):
        w.add_message(ch[i % 2], 1000 * i, b'{"v": %d, "angle": 0.1}' % i, 1000 * i)
    w.finish()
    return buf.getvalue()


SMALL = {"zstd": _small_mcap(CompressionType.ZSTD), "lz4": _small_mcap(CompressionType.LZ4)}


@settings(
    max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    kind=st.sampled_from(["zstd", "lz4"]),
    cut=st.integers(min_value=0, max_value=4000),
    flips=st.lists(st.tuples(st.integers(0, 4000), st.integers(0, 7)), max_size=4),
    length=st.one_of(st.none(), st.tuples(st.integers(0, 4000), st.sampled_from([2**31, 2**63]))),
)
def test_damaged_mcap_gives_data_or_a_clean_error(tmp_path, kind, cut, flips, length):
    buf = bytearray(SMALL[kind])
    for at, bit in flips:
        if at < len(buf):
            buf[at] ^= 1 << bit
    if length is not None and length[0] + 8 <= len(buf):
        buf[length[0] : length[0] + 8] = length[1].to_bytes(8, "little")
    buf = buf[: len(buf) - cut % max(1, len(buf))]
    out = _read(tmp_path, bytes(buf))
    assert isinstance(out, LogData | LogcalInputError)
    if isinstance(out, LogData):
        assert _count(out) <= 60
