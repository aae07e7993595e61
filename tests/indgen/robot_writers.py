"""Writers of ``RobotLog``: JSON MCAP (``mcap`` library) and CSV as logcal reads them.

JSON MCAP: one channel per stream, message encoding ``json``, schema encoding ``jsonschema``;
log time = publish time = the stamp; a dotted field name (``angular_velocity.z``) is written as
a nested object; 2-D fields (``/joint_states`` position, velocity, effort) as arrays; the
stream's constants (joint names) in every message. Messages of all streams in stamp order.
The log's metadata records are written (truth never is).

CSV: ``t`` (s since ``start_ns``) and the ``csv_columns`` of the log, one row per distinct
stamp, empty cells where a stream has no sample at that stamp.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import CompressionType, Writer

from .robotlog import RobotLog, Stream
from .writers import write_csv_rows

__all__ = ["write_csv", "write_log", "write_mcap_json"]


def _schema(s: Stream) -> dict[str, Any]:
    props: dict[str, Any] = {}
    for name, a in s.fields.items():
        node = props
        parts = name.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {"type": "object", "properties": {}})["properties"]
        node[parts[-1]] = (
            {"type": "array", "items": {"type": "number"}} if a.ndim == 2 else {"type": "number"}
        )
    for name in s.constants:
        props[name] = {"type": "array", "items": {"type": "string"}}
    return {"type": "object", "properties": props}


def _message(s: Stream, i: int) -> dict[str, Any]:
    msg: dict[str, Any] = dict(s.constants)
    for name, a in s.fields.items():
        node = msg
        parts = name.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = a[i].tolist() if a.ndim == 2 else float(a[i])
    return msg


def write_mcap_json(path: str | Path, log: RobotLog) -> None:
    """MCAP with JSON messages (see module docstring)."""
    streams = [s for s in log.streams.values() if s.stamps_ns.size]
    with open(path, "wb") as fh:
        w = Writer(fh, compression=CompressionType.ZSTD)
        w.start(profile="", library="indgen")
        ch: dict[str, int] = {}
        for s in streams:
            sid = w.register_schema(
                name=f"indgen{s.topic.replace('/', '.')}",
                encoding="jsonschema",
                data=json.dumps(_schema(s)).encode(),
            )
            ch[s.topic] = w.register_channel(s.topic, "json", sid)
        stamps = np.concatenate([s.stamps_ns for s in streams])
        which = np.concatenate([np.full(s.stamps_ns.size, k) for k, s in enumerate(streams)])
        index = np.concatenate([np.arange(s.stamps_ns.size) for s in streams])
        seq = dict.fromkeys(ch, 0)
        for j in np.argsort(stamps, kind="stable"):
            s, i = streams[int(which[j])], int(index[j])
            t = int(s.stamps_ns[i])
            w.add_message(ch[s.topic], t, json.dumps(_message(s, i)).encode(), t, seq[s.topic])
            seq[s.topic] += 1
        for name, rec in log.metadata.items():
            w.add_metadata(name, dict(rec))
        w.finish()


def write_csv(path: str | Path, log: RobotLog) -> None:
    """CSV of the log's ``csv_columns`` (see module docstring)."""
    used = [
        s
        for s in log.streams.values()
        if any(k[0] == s.topic for k in log.csv_columns) and s.stamps_ns.size
    ]
    stamps = np.unique(np.concatenate([s.stamps_ns for s in used]))
    cols: dict[str, np.ndarray] = {}
    for (topic, name, j), col in log.csv_columns.items():
        s = log.streams.get(topic)
        if s is None or name not in s.fields:
            continue
        a = s.fields[name]
        rows = np.searchsorted(stamps, s.stamps_ns)
        cols[col] = np.full(stamps.size, np.nan)
        cols[col][rows] = a[:, j] if j >= 0 else a
    write_csv_rows(path, (stamps - log.start_ns) / 1e9, cols, list(cols))


def write_log(
    directory: str | Path, log: RobotLog, name: str = "log", fmt: str = "mcap"
) -> dict[str, Path]:
    """Write the log (``fmt`` ``mcap`` or ``csv``) and its extra files into ``directory``;
    returns {"log": path, file name: path, ...}."""
    d = Path(directory)
    out: dict[str, Path] = {}
    for fname, text in log.files.items():
        p = d / fname
        p.write_text(text)
        out[fname] = p
    p = d / f"{name}.{'csv' if fmt == 'csv' else 'mcap'}"
    (write_csv if fmt == "csv" else write_mcap_json)(p, log)
    out["log"] = p
    return out
