"""A log format with its own transform, added from this module and touching no shared file: a
small ULog-like format (PX4's shape: several topics, a ``timestamp`` field in microseconds, the
attitude as an array ``q[4]`` stored w, x, y, z) is registered with ``register_format``, and its
quaternion order with ``register_transform`` (a ``QuaternionLayout``); a channel map names the
transform, and ``logcal analyze`` on the log gives what it gives on the MCAP the log was made
from."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from logtools.channel_map import (
    TRANSFORMS,
    QuaternionLayout,
    load_channel_map,
    quaternion_yaw,
    register_transform,
    resolve_signals,
)
from logtools.cli.main import main
from logtools.readers import LogData, TopicInfo, read_log
from logtools.readers import formats as registry
from logtools.readers.format_reader import FormatReader, ReadRequest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.mcap"
MAGIC = b"ULOGLIKE 1\n"
US = 1_000  # ns per microsecond

# ------------------------------------------------------------------ the format's own module


WXYZ = QuaternionLayout(x="1", y="2", z="3", w="0")
"""PX4's ``q[4]``: w first."""

YAW_FROM_WXYZ = quaternion_yaw("yaw_from_wxyz", WXYZ)


def _flatten(row: dict[str, object]) -> dict[str, float]:
    """Arrays become ``name.i`` columns, as logcal's other readers flatten them."""
    out: dict[str, float] = {}
    for key, value in row.items():
        if isinstance(value, list):
            out.update({f"{key}.{i}": float(v) for i, v in enumerate(value)})
        elif key != "timestamp":
            out[key] = float(value)  # type: ignore[arg-type]
    return out


def _read_ulog_like(name: str, req: ReadRequest) -> LogData:
    """Per topic, a frame of ``t_ns`` (the microsecond ``timestamp`` in ns) and its fields."""
    rows: dict[str, list[dict[str, float]]] = {}
    stamps: dict[str, list[int]] = {}
    with open(name, "rb") as fh:
        fh.readline()
        for line in fh:
            topic, _, body = line.decode().rstrip("\n").partition("\t")
            row = json.loads(body)
            stamps.setdefault(topic, []).append(int(row["timestamp"]) * US)
            rows.setdefault(topic, []).append(_flatten(row))
    topics, info = {}, {}
    for topic, values in rows.items():
        t_ns = stamps[topic]
        topics[topic] = pl.DataFrame(values).insert_column(0, pl.Series("t_ns", t_ns, pl.Int64))
        info[topic] = TopicInfo(topic, topic, "ulog", "ulog", len(t_ns), min(t_ns), max(t_ns))
    return LogData(name, topics, info, {}, [])


ULOG_LIKE = FormatReader(
    "ulog-like",
    "ULog-like export (µs timestamps, PX4 topics)",
    (".ulgl",),
    lambda path, head: head.startswith(MAGIC),
    _read_ulog_like,
)

CHANNEL_MAP = """
[robot]
type = "tractor_trailer"

[signals.psi]
topic = "trailer_hitch"
field = "angle"
[signals.kappa_cmd]
topic = "curvature_setpoint"
field = "curvature"
[signals.v_cmd]
topic = "velocity_setpoint"
field = "v"
[signals.omega_cmd]
topic = "velocity_setpoint"
field = "omega"
[signals.v]
topic = "vehicle_speed"
field = "v"
[signals.omega]
topic = "vehicle_speed"
field = "omega"
[signals.x]
topic = "vehicle_local_position"
field = "x"
[signals.y]
topic = "vehicle_local_position"
field = "y"
[signals.yaw]
topic = "vehicle_attitude"
field = "q"
transform = "yaw_from_wxyz"
"""

# ------------------------------------------------------------------------------ the test


@pytest.fixture
def ulog_like(monkeypatch: pytest.MonkeyPatch) -> Iterator[FormatReader]:
    """The format and its transform registered (both registries restored afterwards)."""
    monkeypatch.setattr(registry, "_REGISTRY", list(registry.formats()))
    before = dict(TRANSFORMS)
    registry.register_format(ULOG_LIKE, first=True)  # the format's one registration line each
    register_transform(YAW_FROM_WXYZ)
    yield ULOG_LIKE
    TRANSFORMS.clear()
    TRANSFORMS.update(before)


def _write(out: Path) -> Path:
    """The sample log's topics under PX4-like names, stamps in µs, the yaw as a w-first q[4]."""
    src = read_log(SAMPLE)
    names = {
        "/hitch/angle": "trailer_hitch",
        "/cmd/curvature": "curvature_setpoint",
        "/cmd/vel": "velocity_setpoint",
        "/odom": "vehicle_speed",
    }
    lines: list[tuple[int, str]] = []
    for topic, frame in src.topics.items():
        assert (frame["t_ns"] % US == 0).all()  # the sample's stamps are whole microseconds
        for row in frame.iter_rows(named=True):
            stamp = row.pop("t_ns") // US
            if topic == "/pose":
                half = row["yaw"] / 2
                quat = [np.cos(half), 0.0, 0.0, np.sin(half)]
                pos = {"timestamp": stamp, "x": row["x"], "y": row["y"]}
                lines.append((stamp, f"vehicle_local_position\t{json.dumps(pos)}"))
                att = {"timestamp": stamp, "q": [float(c) for c in quat]}
                lines.append((stamp, f"vehicle_attitude\t{json.dumps(att)}"))
            else:
                lines.append((stamp, f"{names[topic]}\t{json.dumps({'timestamp': stamp, **row})}"))
    lines.sort(key=lambda pair: pair[0])
    out.write_bytes(MAGIC + "".join(f"{text}\n" for _, text in lines).encode())
    return out


def test_the_format_s_transform_reads_its_quaternion_order(
    ulog_like: FormatReader, tmp_path: Path
) -> None:
    log = read_log(_write(tmp_path / "drive.ulgl"))
    assert log.topics["vehicle_attitude"].columns == ["t_ns", "q.0", "q.1", "q.2", "q.3"]
    cmap = tmp_path / "map.toml"
    cmap.write_text(CHANNEL_MAP)
    got = resolve_signals(log, load_channel_map(cmap))
    want = resolve_signals(read_log(SAMPLE))
    assert got.sources["yaw"].transform == "yaw_from_wxyz"
    for name in ("psi", "kappa_cmd", "v", "omega", "x", "y", "yaw"):
        a, b = got.signals[name], want.signals[name]
        assert a["t_ns"].to_list() == b["t_ns"].to_list(), name
        diff = a["value"].to_numpy() - b["value"].to_numpy()
        if name == "yaw":
            diff = np.angle(np.exp(1j * diff))
        assert np.max(np.abs(diff)) < 1e-12, name


def test_without_the_transform_the_channel_map_is_refused(
    ulog_like: FormatReader, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from logtools.errors import LogcalInputError

    monkeypatch.delitem(TRANSFORMS, YAW_FROM_WXYZ.name)
    cmap = tmp_path / "map.toml"
    cmap.write_text(CHANNEL_MAP)
    with pytest.raises(LogcalInputError, match="transform 'yaw_from_wxyz' is unknown"):
        load_channel_map(cmap)


def test_analyze_on_the_format_gives_the_sample_s_estimate(
    ulog_like: FormatReader, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write(tmp_path / "drive.ulgl")
    cmap = tmp_path / "map.toml"
    cmap.write_text(CHANNEL_MAP)
    fast = ["--json", "--no-discovery", "--repeats", "1"]
    assert main(["analyze", str(log), "--channel-map", str(cmap), *fast]) == 0
    got = json.loads(capsys.readouterr().out)
    assert main(["analyze", str(SAMPLE), *fast]) == 0
    want = json.loads(capsys.readouterr().out)
    assert got["robot"] == want["robot"] == "tractor_trailer"
    assert got["source"]["signals"]["yaw"] == "vehicle_attitude:q"
    for name in ("L1", "L2"):
        assert got["estimate"][name]["value"] == pytest.approx(
            want["estimate"][name]["value"], rel=1e-9
        )
