"""Builders and runners of issue 34's input classes for ``bench/fuzz_all.py``.

* ``lying_mcap``: an MCAP seed rewritten with a statistics record that lies (message counts and
  times up to 2^64 - 1, start after end, spans of centuries); run ``logcal info`` and a window
  plan (``--window`` 0, 10, 600 or automatic) on it: data or a named error, never an
  allocation from the claims.
* ``bag2_struct``: a Foxy ``.db3`` bag whose schema is hostile (views, endless recursive views,
  virtual tables, ``schema`` of the wrong type, garbage QoS profiles in the database or the
  YAML, deep YAML nesting); ``logcal info``: a named error, fast.
* ``stdout``: ``logcal info`` of a seed log (its name hostile: undecodable bytes, ``±``, bidi
  controls) with stdout full (``/dev/full``), closed, a broken pipe, or an ASCII / latin-1 /
  C-locale text stream: exit 2 with one line (quiet on the broken pipe) or exit 0 with the
  text the encoding shows, never a traceback.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import shutil
import sqlite3
import sys
from pathlib import Path
from typing import Any

U64 = 2**64 - 1
YEAR_NS = round(365.25 * 86400 * 1e9)
_BAG: list[Path] = []  # the Foxy bag every bag2_struct input copies (written once per worker)


# ----------------------------------------------------------------------------- lying_mcap


def build_lying_mcap(rng: random.Random, seed_mcap: bytes, folder: Path) -> Path:
    """The seed MCAP with its statistics record (and per-channel counts) lying."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    folder.mkdir(parents=True, exist_ok=True)
    dst = folder / "lying.mcap"
    with dst.open("wb") as out:
        writer = Writer(out)
        writer.start(profile="", library="fuzz lying statistics")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, msg in make_reader(io.BytesIO(seed_mcap)).iter_messages():
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic,
                    channel.message_encoding,
                    schemas.get(channel.schema_id, 0),
                    channel.metadata,
                )
            log_time = msg.log_time
            if rng.random() < 0.02:  # a real jump in the clock, now and then
                log_time += rng.choice((YEAR_NS, 40 * YEAR_NS, 10**18))
            writer.add_message(
                channels[channel.id], log_time, msg.data, msg.publish_time, msg.sequence
            )
        stats = writer._Writer__statistics  # type: ignore[attr-defined]
        lies = (U64, U64 - 1, 2**63, 2**32, 10**12, 0, 1)
        if rng.random() < 0.6:
            stats.message_count = rng.choice(lies)
        if rng.random() < 0.6:
            for cid in stats.channel_message_counts:
                stats.channel_message_counts[cid] = rng.choice(lies)
        if rng.random() < 0.6:
            stats.message_end_time = rng.choice(
                (U64, stats.message_start_time + 100 * YEAR_NS, 0, stats.message_start_time - 1)
            )
        if rng.random() < 0.3:
            stats.message_start_time = rng.choice((0, U64, stats.message_end_time + 1))
        writer.finish()
    return dst


def run_lying_mcap(rng: random.Random, path: Path) -> tuple[str, str]:
    from logtools.cli.main import launch
    from logtools.errors import LogcalInputError
    from logtools.windows import plan_windows

    code = launch(["info", str(path)])
    if code not in (0, 2):
        return "traceback", f"info: exit {code}"
    window = rng.choice((None, 0.0, 10.0, 600.0))
    try:
        plan = plan_windows(path, window)
    except LogcalInputError as err:
        return "clean_error", f"info exit {code}; plan: {str(err)[:200]}"
    windows = 0 if plan is None else len(plan.spans_s)
    return ("ok" if code == 0 else "clean_error"), f"info exit {code}; {windows} windows"


# ----------------------------------------------------------------------------- bag2_struct

_ENDLESS = "WITH RECURSIVE r(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM r)"
_QOS_GARBAGE = (
    "42",
    "[1, 2]",
    "- history: [1]",
    "- {depth: x}",
    "{",
    "- history: 1\n  depth: 1\n  deadline: 3",
    "!!binary AAAA",
    "[" * 200 + "]" * 200,
    "- " * 100 + "x",
    "~",
    "x" * 70_000,
)
_SQL = (
    "ALTER TABLE messages RENAME TO m0; CREATE VIEW messages AS "
    f"{_ENDLESS} SELECT x AS id, 1 AS topic_id, x AS timestamp, X'00' AS data FROM r;",
    "ALTER TABLE messages RENAME TO m0; CREATE VIEW messages AS SELECT * FROM m0;",
    "ALTER TABLE topics RENAME TO t0; CREATE VIEW topics AS SELECT * FROM t0;",
    f"CREATE VIEW schema AS {_ENDLESS} SELECT x AS schema_version FROM r WHERE x < 0;",
    "CREATE TABLE schema(schema_version TEXT, ros_distro TEXT);"
    "INSERT INTO schema VALUES ('four', 7);",
    "CREATE TABLE schema(schema_version INTEGER, ros_distro BLOB);"
    "INSERT INTO schema VALUES (9, X'ff');",
    "CREATE TABLE schema(schema_version INTEGER, ros_distro TEXT);"
    "INSERT INTO schema VALUES (5, 'humble');",
    "CREATE VIRTUAL TABLE message_definitions USING fts5(topic_type);",
    "UPDATE topics SET offered_qos_profiles = X'00ff';",
    "UPDATE topics SET offered_qos_profiles = 12;",
    "UPDATE topics SET name = 7;",
    "DROP TABLE topics; CREATE TABLE topics(id, name);",
)


def _base_bag(folder: Path) -> Path:
    if not _BAG or not _BAG[0].exists():
        from bagmaker import Drive, write_foxy_db3  # type: ignore[import-not-found]

        target = folder / "foxy"
        shutil.rmtree(target, ignore_errors=True)
        _BAG[:] = [write_foxy_db3(target, Drive(duration_s=2.0))]
    return _BAG[0]


def build_bag2_struct(rng: random.Random, seeds_folder: Path, folder: Path) -> Path:
    """A copy of the Foxy bag with one or two hostile structures."""
    base = _base_bag(seeds_folder)
    shutil.rmtree(folder, ignore_errors=True)
    bag = folder / rng.choice(("bag", "b\u202eag", "bag \u00b1"))
    shutil.copytree(base, bag)
    db = next(bag.glob("*.db3"))
    meta = bag / "metadata.yaml"
    for _ in range(rng.choice((1, 1, 2))):
        kind = rng.random()
        if kind < 0.45:
            con = sqlite3.connect(db)
            with contextlib.suppress(sqlite3.Error):
                con.executescript(rng.choice(_SQL))
                con.commit()
            con.close()
        elif kind < 0.7:
            con = sqlite3.connect(db)
            with contextlib.suppress(sqlite3.Error):  # topics may be a view by now
                qos = rng.choice(_QOS_GARBAGE)
                con.execute("UPDATE topics SET offered_qos_profiles = ?", (qos,))
                con.commit()
            con.close()
        elif kind < 0.85:
            qos = rng.choice(_QOS_GARBAGE).replace("'", "''")[:2000]
            text = meta.read_text().replace(
                "offered_qos_profiles: ''", f"offered_qos_profiles: '{qos}'", 1
            )
            meta.write_text(text)
        else:
            depth = rng.choice((65, 1000, 50_000))
            nest = rng.choice(("[" * depth + "]" * depth, "{a: " * depth + "1" + "}" * depth))
            meta.write_text(meta.read_text() + f"  custom_data: {nest}\n")
    return bag


# ----------------------------------------------------------------------------- stdout

_NAMES = (
    b"run_\xff\xfe.csv",
    "run_\u00b1_\u00e9.csv".encode(),
    "r\u202eun.csv".encode(),
    b"run.csv",
)


def run_stdout(rng: random.Random, seed_csv: bytes, folder: Path) -> tuple[str, str]:
    """``logcal info`` of a seed CSV under a hostile stdout; the outcome per the module doc."""
    from logtools.cli.main import launch

    folder.mkdir(parents=True, exist_ok=True)
    name = rng.choice(_NAMES)
    path = os.path.join(os.fsencode(folder), name)
    with open(path, "wb") as fh:
        fh.write(seed_csv)
    mode = rng.choice(("full", "closed", "pipe", "ascii", "latin-1", "C"))
    args = ["info", os.fsdecode(path)]
    saved_fd, saved = os.dup(1), (sys.stdout, sys.stderr)
    sink: Any = None
    reader_fd = None
    try:
        sys.stdout.flush()
        if mode == "full":
            fd = os.open("/dev/full", os.O_WRONLY)
            os.dup2(fd, 1)
            os.close(fd)
            sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), encoding="utf-8")
        elif mode == "closed":
            os.close(1)
            sys.stdout = None  # type: ignore[assignment]  # as Python starts with fd 1 closed
        elif mode == "pipe":
            reader_fd, writer_fd = os.pipe()
            os.close(reader_fd)  # the reader has gone
            reader_fd = None
            os.dup2(writer_fd, 1)
            os.close(writer_fd)
            sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), encoding="utf-8")
        else:
            encoding = "ascii" if mode in ("ascii", "C") else "latin-1"
            sink = io.BytesIO()
            sys.stdout = io.TextIOWrapper(sink, encoding=encoding, write_through=True)
        code = launch(args)
    finally:
        with contextlib.suppress(Exception):
            if sys.stdout is not None:
                sys.stdout.flush()
        os.dup2(saved_fd, 1)
        os.close(saved_fd)
        sys.stdout, sys.stderr = saved
    if mode in ("full", "closed", "pipe"):
        if code != 2:
            return "traceback", f"{mode}: exit {code} (expected 2)"
        return "clean_error", f"{mode}: exit 2"
    if code not in (0, 2):
        return "traceback", f"{mode}: exit {code}"
    text = sink.getvalue() if sink is not None else b""
    if mode != "latin-1" and any(b > 0x7F for b in text):
        return "escape", f"{mode}: bytes beyond ASCII on an ASCII stdout"
    print(text.decode("latin-1"))  # checked for raw controls by the harness
    return ("ok" if code == 0 else "clean_error"), f"{mode}: exit {code}"
