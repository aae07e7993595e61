"""Truncated and corrupted MCAP files: a partial read with problems, or a clear LogcalInputError.

Whatever is read must be true: every value read equals the value written at that log_time.
"""

from __future__ import annotations

import json
import random
import struct

import numpy as np
import pytest

from logtools.errors import LogcalInputError
from logtools.readers import LogData, ProblemKind, read_log
from logtools.readers.mcap_scan import scan_mcap

FRACTIONS = [0.0, 0.002, 0.01, 0.05, 0.2, 0.37, 0.5, 0.63, 0.8, 0.95, 0.99, 0.999]


def _read_or_error(path) -> LogData | LogcalInputError:
    try:
        return read_log(path)
    except LogcalInputError as err:  # the defined failure; anything else fails the test
        return err


def _assert_values_true(log: LogData, truth) -> None:
    """Every sample read is the one written at its timestamp (no garbage from damaged bytes)."""
    index = {int(t): i for i, t in enumerate(truth["t_ns"])}
    pose = log.topics.get("/pose")
    if pose is None or pose.height == 0:
        return
    rows = [index[t] for t in pose["t_ns"].to_list()]
    np.testing.assert_array_equal(pose["x"].to_numpy(), truth["x"][rows])
    np.testing.assert_array_equal(pose["yaw"].to_numpy(), truth["yaw"][rows])


@pytest.fixture(scope="module")
def logs(tmp_path_factory, truth, mcap_writers):
    write_json_mcap = mcap_writers.json
    d = tmp_path_factory.mktemp("trunc")
    return {
        "summary": write_json_mcap(d / "s.mcap", truth, chunk_size=2048).read_bytes(),
        "nosummary": write_json_mcap(
            d / "n.mcap", truth, chunk_size=2048, summary=False
        ).read_bytes(),
        "unchunked": write_json_mcap(
            d / "u.mcap", truth, chunked=False, summary=False
        ).read_bytes(),
    }


@pytest.mark.parametrize("kind", ["summary", "nosummary", "unchunked"])
@pytest.mark.parametrize("fraction", FRACTIONS)
def test_cut_at_offsets(tmp_path, logs, truth, kind, fraction):
    buf = logs[kind]
    cut = int(len(buf) * fraction)
    path = tmp_path / "cut.mcap"
    path.write_bytes(buf[:cut])
    out = _read_or_error(path)
    if isinstance(out, LogcalInputError):
        assert str(path) in str(out)
        assert cut < len(buf) * 0.05  # only a file cut near its start is unreadable
        return
    _assert_values_true(out, truth)
    read = sum(f.height for f in out.topics.values())
    assert read <= 800
    if cut < len(buf):
        kinds = {p.kind for p in out.problems}
        assert kinds & {ProblemKind.TRUNCATED, ProblemKind.NO_FOOTER}, out.problems


def test_unreadable_byte_count_is_exact(tmp_path, logs):
    buf = logs["nosummary"]
    cut = len(buf) // 2
    path = tmp_path / "half.mcap"
    path.write_bytes(buf[:cut])
    log = read_log(path)
    damage = scan_mcap(buf[:cut]).damage
    assert damage.last_good_offset + damage.unreadable_tail_bytes == cut
    assert (log.problems[0].kind, log.problems[0].count) == (
        ProblemKind.TRUNCATED,
        damage.unreadable_tail_bytes,
    )
    # the records before the cut are complete: the next record starts exactly there in the full file
    assert scan_mcap(buf).damage.any is False


def test_flipped_chunk_with_summary_reports_expected_counts_and_span(tmp_path, logs, truth):
    buf = logs["summary"]
    chunk = scan_mcap(buf).chunk_indexes[3]
    damaged = bytearray(buf)
    damaged[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0x55
    path = tmp_path / "flip.mcap"
    path.write_bytes(bytes(damaged))
    log = read_log(path)
    _assert_values_true(log, truth)
    lost = sum(800 // 4 - f.height for f in log.topics.values())
    assert lost > 0
    reported = sum(p.count or 0 for p in log.problems if p.kind is ProblemKind.LOST_MESSAGES)
    assert reported == lost
    spans = [(p.t0_ns, p.t1_ns) for p in log.problems if p.kind is ProblemKind.LOST_CHUNK]
    assert spans == [(chunk.message_start_time, chunk.message_end_time)]


def test_corrupt_chunk_length_resumes_at_next_chunk(tmp_path, logs, truth):
    buf = logs["summary"]
    chunks = scan_mcap(buf).chunk_indexes
    damaged = bytearray(buf)
    damaged[chunks[2].chunk_start_offset + 5] ^= 0x7F  # a high byte of the record length
    path = tmp_path / "len.mcap"
    path.write_bytes(bytes(damaged))
    log = read_log(path)
    _assert_values_true(log, truth)
    assert ProblemKind.CORRUPT_BYTES in {p.kind for p in log.problems}
    last_read = max(f["t_ns"].max() for f in log.topics.values())
    assert last_read == truth["t_ns"][-1]  # chunks after the damage were still read


@pytest.mark.parametrize("kind", ["summary", "nosummary", "unchunked"])
def test_random_byte_flips_never_crash(tmp_path, logs, truth, kind):
    buf = logs[kind]
    rng = random.Random(1234)
    path = tmp_path / "flips.mcap"
    for _ in range(40):
        damaged = bytearray(buf)
        for _ in range(rng.randint(1, 4)):
            damaged[rng.randrange(len(buf))] ^= 1 << rng.randrange(8)
        path.write_bytes(bytes(damaged))
        out = _read_or_error(path)
        if isinstance(out, LogData):
            assert all(f["t_ns"].is_sorted() for f in out.topics.values())
            if kind != "unchunked":  # chunk CRCs guard values; bare messages have no CRC
                _assert_values_true(out, truth)


def test_unchunked_with_summary_counts_what_a_bad_record_hid(tmp_path, truth, mcap_writers):
    buf = mcap_writers.json(tmp_path / "u.mcap", truth, chunked=False).read_bytes()
    i = 100
    payload = json.dumps({f: float(truth[f][i]) for f in ("x", "y", "yaw")}).encode()
    record = buf.index(payload) - 31  # opcode(1) length(8) channel(2) seq(4) times(16)
    damaged = bytearray(buf)
    damaged[record + 7] ^= 0x40  # the record length now runs past the end of the file
    path = tmp_path / "bad.mcap"
    path.write_bytes(bytes(damaged))
    log = read_log(path)
    _assert_values_true(log, truth)
    assert log.topics["/pose"].height == i
    lost = [(p.topic, p.count) for p in log.problems if p.kind is ProblemKind.LOST_MESSAGES]
    assert ("/pose", 200 - i) in lost
    (summary_start,) = struct.unpack_from("<Q", buf, len(buf) - 28)  # from the footer record
    tail = [p.count for p in log.problems if p.kind is ProblemKind.TRUNCATED]
    assert tail == [summary_start - record], log.problems
    assert scan_mcap(bytes(damaged)).damage.last_good_offset == record


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_messages_recovered_from_a_cut_chunk(tmp_path, mcap_writers, compression):
    # 6000 messages, ~400 kB uncompressed: several zstd blocks of 128 kB, so a cut frame still
    # yields its complete blocks.
    truth = mcap_writers.truth(1500)
    one_chunk = mcap_writers.json(
        tmp_path / "one.mcap", truth, compression=compression, chunk_size=10**7
    ).read_bytes()
    (chunk,) = scan_mcap(one_chunk).chunk_indexes
    path = tmp_path / "cut.mcap"
    path.write_bytes(one_chunk[: chunk.chunk_start_offset + chunk.chunk_length * 2 // 3])
    log = read_log(path)
    _assert_values_true(log, truth)
    recovered = sum(f.height for f in log.topics.values())
    assert 6000 * 0.3 < recovered < 6000
    assert scan_mcap(path.read_bytes()).damage.salvaged_messages == recovered
    assert [p.kind for p in log.problems] == [ProblemKind.TRUNCATED]
