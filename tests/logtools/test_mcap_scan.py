"""The MCAP scan finds the same messages through the chunk index (numpy) as record by record."""

from __future__ import annotations

import struct
from io import BytesIO
from pathlib import Path

import numpy as np
import pytest
from mcap.records import Channel
from mcap.writer import CompressionType, IndexType, Writer
from polars.testing import assert_frame_equal

from logtools.readers import mcap_scan
from logtools.readers.decoders import _decode_each, _json_object, decode_json
from logtools.readers.mcap_scan import Payloads, ScanResult, scan_mcap

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"


@pytest.fixture
def index_use(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """Whether each chunk the summary indexes was read through its MessageIndex records."""
    used: list[bool] = []
    read_indexed = mcap_scan._read_indexed

    def spy(*args: object) -> bool:
        used.append(read_indexed(*args))  # type: ignore[arg-type]
        return used[-1]

    monkeypatch.setattr(mcap_scan, "_read_indexed", spy)
    return used


def _messages(scan: ScanResult) -> dict[int, tuple[list[int], list[bytes]]]:
    return {
        cid: (m.log_times.tolist(), list(m.payloads)) for cid, m in sorted(scan.messages.items())
    }


def _write(
    compression: CompressionType,
    *,
    indexed: bool = True,
    chunked: bool = True,
    chunk_size: int = 300,
    late_channel: bool = False,
) -> bytes:
    """Two channels with messages of varying length, interleaved, in many small chunks."""
    buf = BytesIO()
    writer = Writer(
        buf,
        chunk_size=chunk_size,
        compression=compression,
        index_types=IndexType.ALL if indexed else IndexType.NONE,
        use_chunking=chunked,
        use_summary_offsets=indexed,
        use_statistics=indexed,
        repeat_channels=indexed,
        repeat_schemas=indexed,
    )
    writer.start()
    schema = writer.register_schema("s", "jsonschema", b"{}")
    a = writer.register_channel("/a", "json", schema)
    b = writer.register_channel("/b", "json", schema)
    for i in range(200):
        writer.add_message(a, log_time=i, publish_time=i, data=b'{"x":%d}' % i, sequence=i)
        if i % 3 == 0:
            writer.add_message(b, log_time=i, publish_time=i, data=b"y" * (i % 17), sequence=i)
    if late_channel:  # a chunk holding only a channel record: no messages
        writer.register_channel("/c", "json", schema)
    writer.finish()
    return buf.getvalue()


@pytest.mark.parametrize("compression", list(CompressionType))
@pytest.mark.parametrize("late_channel", [False, True])
def test_indexed_scan_equals_unindexed_and_unchunked(
    compression: CompressionType, late_channel: bool, index_use: list[bool]
) -> None:
    indexed = scan_mcap(_write(compression, late_channel=late_channel))
    assert index_use
    assert all(index_use)
    assert len(indexed.chunk_indexes) > 5
    assert not indexed.damage.any
    expected = _messages(scan_mcap(_write(compression, indexed=False)))
    assert _messages(indexed) == expected
    assert _messages(scan_mcap(_write(compression, chunked=False))) == expected
    assert sum(len(t) for t, _ in expected.values()) == 200 + 67
    assert {c.topic for c in indexed.channels.values()} >= {"/a", "/b"}
    if late_channel:
        assert "/c" in {c.topic for c in indexed.channels.values()}


def _first_index_entries(buf: bytes, scan: ScanResult) -> list[int]:
    """File offset of the first (log_time, offset) entry of each chunk's first MessageIndex."""
    out = []
    for ci in sorted(scan.chunk_indexes, key=lambda c: c.chunk_start_offset):
        for where in ci.message_index_offsets.values():
            (nbytes,) = struct.unpack_from("<I", buf, where + 11)
            if nbytes:
                out.append(where + 15)
                break
    return out


@pytest.mark.parametrize("field", ["log_time", "offset"])
def test_a_message_index_that_disagrees_with_the_records_is_not_trusted(
    field: str, index_use: list[bool]
) -> None:
    buf = _write(CompressionType.ZSTD)
    truth = scan_mcap(buf)
    assert all(index_use)
    index_use.clear()
    damaged = bytearray(buf)
    entries = _first_index_entries(buf, truth)[::2]
    for entry in entries:
        at = entry + (0 if field == "log_time" else 8)
        (value,) = struct.unpack_from("<Q", damaged, at)
        struct.pack_into("<Q", damaged, at, value + 3)
    scan = scan_mcap(bytes(damaged))
    assert index_use.count(False) == len(entries) > 3  # those chunks were walked instead
    assert _messages(scan) == _messages(truth)
    assert not scan.damage.any


def test_every_sample_log_scans_alike_with_and_without_its_index() -> None:
    for path in sorted(SAMPLES.glob("*.mcap")):
        buf = path.read_bytes()
        scan = scan_mcap(buf)
        if not scan.chunk_indexes:
            continue
        no_summary = bytearray(buf)
        footer = len(buf) - 8 - 29
        no_summary[footer:] = b"\x00" * (len(buf) - footer)  # footer gone: walked record by record
        walked = scan_mcap(bytes(no_summary))
        assert _messages(walked) == _messages(scan), path.name


def test_payloads_behave_as_a_sequence_of_bytes() -> None:
    items = [b"", b"ab", b"cde"]
    p = Payloads.from_bytes(items)
    assert len(p) == 3
    assert list(p) == items
    assert (p[1], p[-1]) == (b"ab", b"cde")
    assert list(p[1:]) == items[1:]


def _json_channel() -> Channel:
    return Channel(id=1, topic="/t", message_encoding="json", schema_id=0, metadata={})


def _scattered(payloads: list[bytes]) -> Payloads:
    """Payloads as views with filler between them; the last one ends the buffer."""
    parts, starts, at = [], [], 0
    for i, p in enumerate(payloads):
        filler = b"\n\r{" * (i % 3)
        parts += [filler, p]
        starts.append(at + len(filler))
        at += len(filler) + len(p)
    lengths = np.array([len(p) for p in payloads], dtype=np.int64)
    buffer = np.frombuffer(b"".join(parts), dtype=np.uint8)
    return Payloads(buffer, np.array(starts, dtype=np.int64), lengths)


@pytest.mark.parametrize(
    "payloads",
    [
        [b'{"a":1}', b'{"a":\n2}', b'{"a":3}\r', b'{"a":\r\n4,"b":"x"}'],
        [b'{"a":1}', b"", b'{"a":2}'],
        [b'{"a":1}', b"1", b'{"a":2}'],
        [b'{"a":1}{"a":2}', b'{"a":3}'],
        [b'{"v":%d,"s":"%s"}' % (i, b"x" * (i % 50)) for i in range(9000)],
        [b'{"t":%d,"a":0.5}' % i for i in range(5000)] + [b'{"t":1,"a":1.0,"late":3.5}'],
        [b'{"t":%d,"a":0.5}' % i for i in range(5000)] + [b'{"t":1,"renamed":1.0}'],
        [b'{"t":%d,"a":0.5}' % i for i in range(5000)] + [b'{"t":1,"a":1.0,"z":{"q":2}}'],
    ],
    ids=[
        "line-breaks",
        "empty",
        "not-an-object",
        "two-objects",
        "blocks-of-varying-width",
        "field-first-seen-late",
        "field-renamed-late",
        "nested-field-first-seen-late",
    ],
)
def test_json_bulk_from_views_equals_per_message(payloads: list[bytes]) -> None:
    each = _decode_each(payloads, _json_object)
    for given in (payloads, _scattered(payloads)):
        bulk = decode_json(None, _json_channel(), given)
        assert bulk.kept == each.kept
        assert_frame_equal(bulk.frame, each.frame, check_exact=True)
