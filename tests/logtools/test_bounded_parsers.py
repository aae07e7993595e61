"""Every decompressor, parser and expander is bounded ("a log is data, never instructions").

One test per class the red team found. The hostile inputs are built here, small on disk; where
memory is the point the read runs in a subprocess under ``RLIMIT_AS`` and must end in exit 2
(a clean ``LogcalInputError``) or data, within a time bound.
"""

from __future__ import annotations

import bz2
import json
import sqlite3
import struct
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import lz4.frame
import numpy as np
import polars as pl
import pytest
import zstandard
from bagmaker import Drive, write_foxy_db3, write_ros1

from logtools.errors import ChannelMapEntryError, ChannelMapError, LogcalInputError
from logtools.problems import ProblemKind
from logtools.readers import read_log

CAP = 1536 * 2**20  # address space of a capped read (the interpreter, polars and numpy: ~600 MB)
_RUNNER = textwrap.dedent(
    """
    import json, resource, sys
    resource.setrlimit(resource.RLIMIT_AS, ({cap}, {cap}))
    from logtools.errors import LogcalInputError
    from logtools.readers import read_log
    try:
        log = read_log(sys.argv[1])
    except LogcalInputError as err:
        print(err, file=sys.stderr)
        sys.exit(2)
    print(json.dumps({{"problems": [p.kind.value for p in log.problems],
                      "topics": {{t: f.shape for t, f in log.topics.items()}}}}))
    """
)


def capped_read(path: Path, cap: int = CAP, timeout: float = 60.0) -> tuple[int, str, str, float]:
    """(exit code, stdout, stderr, seconds) of ``read_log(path)`` in a capped subprocess."""
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _RUNNER.format(cap=cap), str(path)],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    return proc.returncode, proc.stdout, proc.stderr, time.perf_counter() - t0


# ----------------------------------------------------------------------------- ROS 1 chunks


def _ros1_records(buf: bytes) -> list[tuple[int, dict[str, bytes], int, int]]:
    """(offset, header fields, data offset, data length) of each top-level record."""
    out = []
    pos = buf.index(b"\n") + 1
    while pos < len(buf):
        (hlen,) = struct.unpack_from("<I", buf, pos)
        header = buf[pos + 4 : pos + 4 + hlen]
        fields: dict[str, bytes] = {}
        at = 0
        while at < len(header):
            (n,) = struct.unpack_from("<I", header, at)
            k, _, v = header[at + 4 : at + 4 + n].partition(b"=")
            fields[k.decode()] = v
            at += 4 + n
        (dlen,) = struct.unpack_from("<I", buf, pos + 4 + hlen)
        out.append((pos, fields, pos + 8 + hlen, dlen))
        pos += 8 + hlen + dlen
    return out


def _ros1_bomb(tmp_path: Path, kind: str, extra: int) -> Path:
    """A ROS 1 bag whose first chunk, compressed with ``kind``, holds ``extra`` zero bytes
    beyond what it declares (the index still points at its real records)."""
    drive = Drive(duration_s=2.0, stall=None)
    bag = write_ros1(tmp_path / "plain.bag", drive)
    buf = bytearray(bag.read_bytes())
    records = _ros1_records(bytes(buf))
    pos, fields, at, dlen = next(r for r in records if r[1]["op"] == b"\x05")
    assert fields["compression"] == b"none"
    raw = bytes(buf[at : at + dlen])
    if kind == "bz2":  # concatenated streams: bz2.decompress reads them all
        stream = bz2.compress(bytes(8 * 2**20), 1)
        data = bz2.compress(raw) + stream * (extra // (8 * 2**20))
    else:
        data = lz4.frame.compress(raw + bytes(extra))
    # the chunk header again, with compression=kind (its size field: still the real records)
    fields = {**fields, "compression": kind.encode()}
    header = b"".join(
        struct.pack("<I", len(k) + 1 + len(v)) + k.encode() + b"=" + v for k, v in fields.items()
    )
    new = struct.pack("<I", len(header)) + header + struct.pack("<I", len(data)) + data
    old_len = at + dlen - pos
    buf[pos : at + dlen] = new
    delta = len(new) - old_len
    # the bag header's index_pos moves with everything after the chunk
    bh_pos, bh_fields, _, _ = records[0]
    (index_pos,) = struct.unpack("<Q", bh_fields["index_pos"])
    at_field = bytes(buf).index(b"index_pos=", bh_pos) + len(b"index_pos=")
    buf[at_field : at_field + 8] = struct.pack("<Q", index_pos + delta)
    out = tmp_path / f"{kind}_bomb.bag"
    out.write_bytes(bytes(buf))
    return out


@pytest.mark.parametrize(("kind", "extra"), [("bz2", 2**32), ("lz4", 120 * 2**20)])
def test_ros1_chunk_bombs_are_refused_within_the_cap(tmp_path: Path, kind: str, extra: int) -> None:
    bomb = _ros1_bomb(tmp_path, kind, extra)
    assert bomb.stat().st_size < 600_000
    code, out, err, secs = capped_read(bomb)
    assert code == 2, (out, err[-2000:])
    assert "decompresses to more than" in err
    assert kind in err
    assert secs < 30


def test_a_well_formed_compressed_ros1_chunk_still_reads(tmp_path: Path) -> None:
    bomb = _ros1_bomb(tmp_path, "bz2", 0)  # the same bag, its chunk bz2-compressed honestly
    log = read_log(bomb)
    assert log.topics
    assert not log.problems


# ----------------------------------------------------------------------------- rosbag2


def _foxy(tmp_path: Path) -> Path:
    return write_foxy_db3(tmp_path / "bag", Drive(duration_s=3.0, stall=None))


def _set_meta(folder: Path, old: str, new: str) -> None:
    meta = folder / "metadata.yaml"
    text = meta.read_text()
    assert old in text, text
    meta.write_text(text.replace(old, new, 1))


def test_rosbag2_file_compression_bomb_is_refused(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    db = next(folder.glob("*.db3"))
    # a storage "file" of 1 GiB of zeros, zstd-compressed to a few KB
    zc = zstandard.ZstdCompressor(level=3)
    with open(folder / (db.name + ".zstd"), "wb") as fh, zc.stream_writer(fh) as w:
        chunk = bytes(16 * 2**20)
        for _ in range(64):
            w.write(chunk)
    _set_meta(folder, f"- {db.name}", f"- {db.name}.zstd")
    _set_meta(
        folder,
        "compression_format: ''\n  compression_mode: ''",
        "compression_format: zstd\n  compression_mode: FILE",
    )
    assert sum(p.stat().st_size for p in folder.iterdir()) < 2_000_000
    code, out, err, secs = capped_read(folder)
    assert code == 2, (out, err[-2000:])
    assert "decompresses to more than the budget" in err
    assert secs < 30


def test_rosbag2_file_compression_reads_an_honest_bag(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    db = next(folder.glob("*.db3"))
    (folder / (db.name + ".zstd")).write_bytes(zstandard.ZstdCompressor().compress(db.read_bytes()))
    db.unlink()
    _set_meta(folder, f"- {db.name}", f"- {db.name}.zstd")
    _set_meta(
        folder,
        "compression_format: ''\n  compression_mode: ''",
        "compression_format: zstd\n  compression_mode: FILE",
    )
    log = read_log(folder)
    assert len(log.topics) == 6
    assert not log.problems


def _message_compressed(folder: Path, payload: bytes | None = None) -> None:
    db = next(folder.glob("*.db3"))
    con = sqlite3.connect(db)
    zc = zstandard.ZstdCompressor()
    rows = con.execute("SELECT id, data FROM messages").fetchall()
    for mid, data in rows:
        con.execute("UPDATE messages SET data = ? WHERE id = ?", (zc.compress(data), mid))
    if payload is not None:
        con.execute("UPDATE messages SET data = ? WHERE id = ?", (payload, rows[0][0]))
    con.commit()
    con.close()
    _set_meta(
        folder,
        "compression_format: ''\n  compression_mode: ''",
        "compression_format: zstd\n  compression_mode: MESSAGE",
    )


def test_rosbag2_message_compression_bomb_is_refused_within_the_cap(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    zc = zstandard.ZstdCompressor(level=3)
    bomb = zc.compress(bytes(512 * 2**20))
    _message_compressed(folder, bomb)
    code, out, err, secs = capped_read(folder)
    assert code == 2, (out, err[-2000:])
    assert "decompress to more than the budget" in err
    assert secs < 30


def test_rosbag2_message_compression_non_zstd_payload_is_dropped(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    _message_compressed(folder, b"not zstd at all")
    log = read_log(folder)
    dropped = [p for p in log.problems if p.kind is ProblemKind.DROPPED_MESSAGES]
    assert len(dropped) == 1
    assert dropped[0].count == 1
    assert "not zstd" in dropped[0].message
    assert len(log.topics) == 6


def test_yaml_alias_bomb_in_metadata_is_refused_fast(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    lol = ["  l0: &l0 [x, x, x, x, x, x, x, x, x]"]
    lol += [f"  l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]" for i in range(1, 10)]
    meta = folder / "metadata.yaml"
    text = meta.read_text()
    meta.write_text("\n".join(["bombs:", *lol]) + "\n" + text + "  custom_data:\n    bomb: *l9\n")
    assert meta.stat().st_size < 5000
    code, out, err, secs = capped_read(folder)
    assert code == 2, (out, err[-2000:])
    assert "YAML nodes" in err
    assert secs < 20


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        (
            "  message_count: ",
            "  message_count: many #",
            "rosbag2_bagfile_information.message_count",
        ),
        ("  version: 4", "  version: [4]", "rosbag2_bagfile_information.version"),
        ("        name: /cmd_vel", "        name: {a: 1}", "topic_metadata.name"),
        ("  storage_identifier: sqlite3", "  storage_identifier: 3", "storage_identifier"),
        ("  compression_mode: ''", "  compression_mode: [x]", "compression_mode"),
        ("rosbag2_bagfile_information:", "rosbag2_bagfile_information: 3\nx:", "a mapping"),
    ],
)
def test_wrong_yaml_types_name_the_key(tmp_path: Path, old: str, new: str, key: str) -> None:
    folder = _foxy(tmp_path)
    _set_meta(folder, old, new)
    with pytest.raises(LogcalInputError) as info:
        read_log(folder)
    assert key in str(info.value)


def _db(folder: Path) -> sqlite3.Connection:
    return sqlite3.connect(next(folder.glob("*.db3")))


def test_db3_integer_payload_is_dropped_not_allocated(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    con = _db(folder)
    con.execute("UPDATE messages SET data = 3000000000 WHERE id = 1")
    con.commit()
    con.close()
    code, out, err, _ = capped_read(folder, cap=1536 * 2**20)
    assert code == 0, err[-2000:]
    assert "dropped_messages" in json.loads(out)["problems"]
    log = read_log(folder)
    (p,) = [p for p in log.problems if p.kind is ProblemKind.DROPPED_MESSAGES]
    assert p.count == 1
    assert "int, not bytes" in p.message


def test_db3_wrong_sql_types(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    con = _db(folder)
    con.execute("UPDATE messages SET timestamp = 'soon' WHERE id = 2")
    con.commit()
    con.close()
    with pytest.raises(LogcalInputError, match="table messages, column timestamp: 1 rows"):
        read_log(folder)
    con = _db(folder)
    con.execute("UPDATE messages SET timestamp = 5 WHERE id = 2")
    con.execute("UPDATE topics SET name = X'00ff' WHERE id = 1")  # TEXT affinity keeps blobs
    con.commit()
    con.close()
    with pytest.raises(LogcalInputError, match="table topics, column name"):
        read_log(folder)


def test_db3_messages_of_unknown_topic_ids_are_reported(tmp_path: Path) -> None:
    folder = _foxy(tmp_path)
    con = _db(folder)
    con.execute("UPDATE messages SET topic_id = 99 WHERE id <= 5")
    con.commit()
    con.close()
    log = read_log(folder)
    (p,) = [p for p in log.problems if p.kind is ProblemKind.UNKNOWN_CHANNEL]
    assert p.count == 5
    assert "topic_id" in p.message


# ----------------------------------------------------------------------------- JSON width


def _json_mcap(path: Path, messages: list[bytes], topic: str = "/wide") -> Path:
    from mcap.writer import Writer

    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("wide", "jsonschema", b"{}")
        cid = w.register_channel(topic, "json", sid)
        for i, data in enumerate(messages):
            w.add_message(cid, log_time=10**9 + i * 10**7, data=data, publish_time=0)
        w.finish()
    return path


def test_json_objects_whose_keys_all_differ_stay_within_the_budget(tmp_path: Path) -> None:
    # one array of 40,000 objects, each with its own key (polars would unify them into one
    # struct of 40,000 fields for every item: 1.6 G cells), then ordinary messages
    items = ",".join(f'{{"k{i}":{i}}}' for i in range(40_000))
    msgs = [f'{{"v":0.5,"arr":[{items}]}}'.encode()]
    msgs += [f'{{"v":{i / 10},"arr":[{{"k0":1}}]}}'.encode() for i in range(200)]
    path = _json_mcap(tmp_path / "wide.mcap", msgs)
    assert path.stat().st_size < 700_000
    code, out, err, secs = capped_read(path)
    assert code == 0, err[-3000:]
    result = json.loads(out)
    rows, cols = result["topics"]["/wide"]
    assert rows == 201
    assert cols <= 4097
    assert secs < 60


def test_many_messages_with_distinct_keys_are_capped_by_cells(tmp_path: Path) -> None:
    msgs = [f'{{"v":{i},"x{i}":1}}'.encode() for i in range(30_000)]
    path = _json_mcap(tmp_path / "sparse.mcap", msgs)
    log = read_log(path)
    frame = log.topics["/wide"]
    assert frame.height == 30_000
    budget = 2**22 + sum(map(len, msgs))  # CELL_BUDGET_BASE + 1 cell per payload byte
    assert frame.height * (frame.width - 1) <= budget  # t_ns aside
    (p,) = [p for p in log.problems if p.kind is ProblemKind.UNDECODABLE]
    assert p.count
    assert p.count >= 30_000 - frame.width


def test_json_key_with_a_dot_beside_the_same_path_keeps_the_first(tmp_path: Path) -> None:
    msgs = [f'{{"a.b":{i},"a":{{"b":{-i}}},"c":1}}'.encode() for i in range(50)]
    msgs.append(b'{"a.b":7,"a":{"b":-7},"c":"x"}')  # not uniform: the general route
    log = read_log(_json_mcap(tmp_path / "dup.mcap", msgs))
    frame = log.topics["/wide"]
    assert frame.columns.count("a.b") == 1
    assert frame["a.b"].to_list()[:3] == [0, 1, 2]


# ----------------------------------------------------------------------------- CSV


def test_a_csv_300000_columns_wide_is_refused_before_parsing(tmp_path: Path) -> None:
    path = tmp_path / "wide.csv"
    names = ",".join(["t", *(f"c{i}" for i in range(300_000))])
    path.write_text(names + "\n" + ",".join(["0"] * 300_001) + "\n")
    code, out, err, secs = capped_read(path, cap=1024 * 2**20)
    assert code == 2, (out, err[-2000:])
    assert "columns; logcal reads at most 4096" in err
    assert secs < 20


def test_a_large_csv_streams_and_gives_the_same_frame(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from logtools.readers import csv_reader

    n = 20_000
    t = np.arange(n) * 0.01
    path = tmp_path / "log.csv"
    pl.DataFrame({"t": t, "v": np.sin(t), "mode": ["a"] * n}).write_csv(path)
    whole = read_log(path)
    monkeypatch.setattr(csv_reader, "STREAM_MIN_BYTES", 1)
    streamed = read_log(path)
    assert streamed.topics["csv"].equals(whole.topics["csv"])
    assert streamed.problems == whole.problems


def test_relative_milliseconds_are_named_and_rescaled(tmp_path: Path) -> None:
    path = tmp_path / "ms.csv"
    t = np.arange(3000) * 10  # 100 Hz written in relative ms: 0, 10, 20, ...
    pl.DataFrame({"t": t, "v": np.ones(3000)}).write_csv(path)
    log = read_log(path)
    (p,) = [p for p in log.problems if p.kind is ProblemKind.TIME_UNIT]
    assert "relative ms" in p.message
    stamps = log.topics["csv"]["t_ns"].to_numpy()
    assert stamps[-1] - stamps[0] == 29_990_000_000  # 29.99 s, not 8 hours


# ----------------------------------------------------------------------------- channel maps


def _cmap(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "map.toml"
    path.write_text(text)
    return path


def test_deep_formula_is_one_clear_error(tmp_path: Path) -> None:
    from logtools.channel_map import load_channel_map

    for text in ("(" * 5000 + "v" + ")" * 5000, "-" * 5000 + "v", "+".join(["v"] * 600)):
        path = _cmap(tmp_path, f'[signals.omega]\nformula = "{text}"\n')
        with pytest.raises(ChannelMapEntryError, match=r"signals\.omega\.formula"):
            load_channel_map(path)
    path = _cmap(tmp_path, '[signals.omega]\nformula = "' + "-" * 998 + 'v"\n')
    with pytest.raises(ChannelMapEntryError, match="nested too deeply"):  # short, but deep
        load_channel_map(path)


def test_deep_toml_is_one_clear_error(tmp_path: Path) -> None:
    from logtools.channel_map import load_channel_map

    path = _cmap(tmp_path, "x = " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(ChannelMapError, match=r"nested too deeply|not a readable TOML"):
        load_channel_map(path)
    big = _cmap(tmp_path, "# " + "x" * (2**20 + 10) + "\n")
    with pytest.raises(ChannelMapError, match="larger than"):
        load_channel_map(big)


@pytest.mark.parametrize(
    ("entry", "key"),
    [
        ('topic = "/a"\nfield = "b"\nunit = ["deg"]', "signals.psi.unit"),
        ('topic = "/a"\nfield = "b"\ntransform = ["deg_to_rad"]', "signals.psi.transform"),
        ('topic = "/a"\nfield = "b"\nstamp = {x = 1}', "signals.psi.stamp"),
        ('formula = ["v"]', "signals.psi.formula"),
    ],
)
def test_wrong_toml_types_name_the_key(tmp_path: Path, entry: str, key: str) -> None:
    from logtools.channel_map import load_channel_map

    with pytest.raises(ChannelMapEntryError) as info:
        load_channel_map(_cmap(tmp_path, f"[signals.psi]\n{entry}\n"))
    assert info.value.key == key


def test_non_numeric_nominal_metadata_is_dropped_and_reported(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "meta.mcap"
    with open(path, "wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("s", "jsonschema", b"{}")
        cid = w.register_channel("/cmd", "json", sid)
        for i in range(5):
            w.add_message(cid, log_time=i * 10**8, data=b'{"v":1.0}', publish_time=0)
        w.add_metadata("logcal.nominal", {"track_width": "wide", "wheel_radius_left": "0.1"})
        w.add_metadata("logcal", {"robot": "manipulator_2link", "nominal.m1": "[1]", "l1": "nan"})
        w.finish()
    log = read_log(path)
    assert log.metadata["logcal.nominal"] == {"wheel_radius_left": "0.1"}
    assert log.metadata["logcal"] == {"robot": "manipulator_2link"}
    notes = [p.message for p in log.problems if "metadata record" in p.message]
    assert len(notes) == 3
    assert any("'track_width'" in n for n in notes)
