"""Channel maps: [robot], scale/offset/unit, formulas (safe), header stamps,
off = true, and one clear error naming the TOML file and key for every bad map; gaps."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from mcap.writer import Writer

from logtools.align import find_gaps
from logtools.channel_map import ChannelMap, load_channel_map, resolve_signals
from logtools.cli.main import main
from logtools.errors import ChannelMapEntryError, ChannelMapError, LogcalInputError
from logtools.load import load_log
from logtools.readers import read_log
from logtools.signals import Formula, FormulaError, OriginKind, SignalSource, Stamp

TOPICS = {
    "/enc": {"deg": "psi_deg"},
    "/cmd": {"steer": "steer_deg", "speed": "v"},
    "/odom": {"v": "v", "omega": "omega"},
    "/pose": {"x": "x", "y": "y", "yaw": "yaw"},
}


@pytest.fixture
def log_path(tmp_path, truth, mcap_writers):
    data = {
        **truth,
        "psi_deg": (np.degrees(truth["psi"]) + 1.0) / 2.0,  # psi = (2 * deg - 1) deg
        "steer_deg": np.degrees(np.arctan(2.0 * truth["kappa_cmd"])),  # wheelbase 2 m
    }
    return mcap_writers.json(tmp_path / "steer.mcap", data, topics=TOPICS)


def _toml(tmp_path, text, name="map.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


GOOD = """
[robot]
type = "tractor_trailer"
wheelbase = 2.0
L2 = 2.5

[signals.psi]
topic = "/enc"
field = "deg"
unit = "deg"
scale = 2.0
offset = -1.0

[signals.steer_cmd]
topic = "/cmd"
field = "steer"
unit = "deg"

[signals.v_cmd]
topic = "/cmd"
field = "speed"
unit = "km/h"

[signals.kappa_cmd]
formula = "tan(steer_cmd) / wheelbase"

[signals.omega]
off = true
"""


def test_scale_offset_unit_formula_and_off(tmp_path, truth, log_path):
    cmap = load_channel_map(_toml(tmp_path, GOOD))
    assert isinstance(cmap, ChannelMap)
    assert cmap.robot.type == "tractor_trailer"
    assert cmap.robot.number("wheelbase") == 2.0
    assert cmap.robot.params == {"wheelbase": 2.0, "L2": 2.5}
    assert cmap.off == frozenset({"omega"})
    assert cmap["psi"] == SignalSource("/enc", "deg", None, 2.0, -1.0, "deg")
    res = resolve_signals(read_log(log_path), cmap)
    np.testing.assert_allclose(res.signals["psi"]["value"].to_numpy(), truth["psi"], atol=1e-12)
    np.testing.assert_allclose(res.signals["v_cmd"]["value"].to_numpy(), truth["v"] / 3.6)
    np.testing.assert_allclose(
        res.signals["kappa_cmd"]["value"].to_numpy(), truth["kappa_cmd"], atol=1e-12
    )
    origin = res.origins.get("kappa_cmd")
    assert origin is not None
    assert origin.kind is OriginKind.FORMULA
    assert not origin.by_robot
    assert res.sources["kappa_cmd"].describe() == "= tan(steer_cmd) / wheelbase"
    assert "omega" not in res.signals
    loaded = load_log(log_path, cmap)
    assert "omega" not in loaded.frame.columns
    assert set(loaded.frame["kappa_source"].drop_nulls().unique().to_list()) == {"path"}


def test_formula_across_topics_at_other_rates(tmp_path):
    """Inputs on different time bases are interpolated onto the densest one."""
    path = tmp_path / "rates.mcap"
    with path.open("wb") as fh:
        w = Writer(fh)
        w.start()
        sid = w.register_schema("s", "jsonschema", b"{}")
        a, b = w.register_channel("/a", "json", sid), w.register_channel("/b", "json", sid)
        for i in range(100):  # /a at 100 Hz: a = t
            t = i * 10_000_000
            w.add_message(a, t, json.dumps({"v": i * 0.01}).encode(), t)
        for i in range(11):  # /b at 10 Hz: b = 2 t
            t = i * 100_000_000
            w.add_message(b, t, json.dumps({"v": i * 0.2}).encode(), t)
        w.finish()
    cmap = load_channel_map(
        _toml(
            tmp_path,
            '[signals.x]\ntopic = "/a"\nfield = "v"\n[signals.y]\ntopic = "/b"\nfield = "v"\n'
            '[signals.kappa_cmd]\nformula = "y - 2 * x + 1"\n',
        )
    )
    res = resolve_signals(read_log(path), cmap)
    kappa_cmd = res.signals["kappa_cmd"]
    assert kappa_cmd.height == 100
    np.testing.assert_allclose(kappa_cmd["value"].to_numpy(), 1.0, atol=1e-12)


def test_header_stamp_needs_a_header(tmp_path, log_path):
    cmap = load_channel_map(
        _toml(tmp_path, '[signals.psi]\ntopic = "/enc"\nfield = "deg"\nstamp = "header"\n')
    )
    assert cmap["psi"].stamp is Stamp.HEADER
    with pytest.raises(ChannelMapEntryError, match=r"map.toml: \[signals.psi.stamp\].*no header"):
        resolve_signals(read_log(log_path), cmap)


def test_formula_naming_an_absent_signal(tmp_path, log_path):
    cmap = load_channel_map(_toml(tmp_path, '[signals.kappa_cmd]\nformula = "steer_cmd / 2"\n'))
    with pytest.raises(
        ChannelMapEntryError, match=r"\[signals.kappa_cmd.formula\].*uses steer_cmd.*does not have"
    ):
        resolve_signals(read_log(log_path), cmap)


@pytest.mark.parametrize(
    ("text", "key", "needle"),
    [
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\nunit = "furlong"\n', "signals.psi.unit", "rad"),
        ('[signals.v]\ntopic = "/a"\nfield = "b"\nunit = "deg"\n', "signals.v.unit", "m/s, km/h"),
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\nscale = "2"\n', "signals.psi.scale", "number"),
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\nscale = 0\n', "signals.psi.scale", "nothing"),
        (
            '[signals.psi]\ntopic = "/a"\nfield = "b"\nstamp = "gps"\n',
            "signals.psi.stamp",
            "header",
        ),
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\ncolour = 1\n', "signals.psi.colour", "formula"),
        ('[signals.psi]\noff = true\ntopic = "/a"\n', "signals.psi.off", "drop the other keys"),
        ('[signals.psi]\noff = "yes"\n', "signals.psi.off", "true or false"),
        ("[signals.psi]\nformula = \"__import__('os')\"\n", "signals.psi.formula", "calls only"),
        ('[signals.psi]\nformula = "x.real"\n', "signals.psi.formula", "Attribute"),
        ('[signals.psi]\nformula = "x ** 2"\n', "signals.psi.formula", "+ - * /"),
        ('[signals.psi]\nformula = "x +"\n', "signals.psi.formula", "does not parse"),
        ('[signals.psi]\nformula = "speed / 2"\n', "signals.psi.formula", "'speed'"),
        ('[signals.psi]\nformula = "psi + 1"\n', "signals.psi.formula", "itself"),
        ('[signals.psi]\nformula = "x"\ntopic = "/a"\n', "signals.psi.formula", "drop topic"),
        (
            '[signals.x]\nformula = "y + 1"\n[signals.y]\nformula = "x - 1"\n',
            "signals.x.formula",
            "circular: x -> y -> x",
        ),
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\nframe = 3\n', "signals.psi.frame", "frame"),
        ('[robot]\ntype = "boat"\n', "robot.type", "tractor_trailer"),
        ("[robot]\nwheelbase = -1\n", "robot.wheelbase", "positive"),
        ('[robot]\nL1 = "long"\n', "robot.L1", "number"),
        ('[tf]\nparent = "map"\n', "tf.parent", "child_frame"),
        ('[signals.psi]\ntopic = "/a"\nfield = "b"\n[extra]\na = 1\n', "extra", "[robot]"),
    ],
)
def test_bad_maps_give_one_error_naming_file_and_key(tmp_path, text, key, needle):
    path = _toml(tmp_path, text, "bad.toml")
    with pytest.raises(ChannelMapEntryError) as info:
        load_channel_map(path)
    err = info.value
    assert (err.file, err.key) == (str(path), key)
    assert str(err).startswith(f"{path}: [{key}]")
    assert needle in str(err)
    assert isinstance(err, ChannelMapError)
    assert isinstance(err, LogcalInputError)


def test_cli_bad_map_exits_2_with_the_message(tmp_path, log_path, capsys):
    bad = _toml(
        tmp_path, '[signals.psi]\ntopic = "/enc"\nfield = "deg"\nunit = "deg/s"\n', "b.toml"
    )
    assert main(["info", "--channel-map", str(bad), str(log_path)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}: [signals.psi.unit]" in err
    assert err.count("logcal: error:") == 1


def test_map_with_off_only_switches_a_default_off(tmp_path, truth, mcap_writers):
    path = mcap_writers.json(tmp_path / "d.mcap", truth)
    cmap = load_channel_map(_toml(tmp_path, "[signals.omega]\noff = true\n"))
    res = resolve_signals(read_log(path), cmap)
    assert "omega" not in res.signals
    assert "v" in res.signals
    assert "omega" in res.missing


def test_formula_is_evaluated_without_eval():
    f = Formula.parse("atan2(y, x) + sqrt(4) - -pi + abs(-1) * cos(0) / 2")
    assert f.names == ("x", "y")
    got = f.evaluate({"x": np.array([1.0, 0.0]), "y": np.array([1.0, 1.0])})
    np.testing.assert_allclose(got, [math.pi / 4 + 2.5 + math.pi, math.pi / 2 + 2.5 + math.pi])
    for bad in ("(lambda: 1)()", "x[0]", "x if y else 1", "x < y", "'a'", "True", "f(x)", "x @ y"):
        with pytest.raises(FormulaError):
            Formula.parse(bad)
    with pytest.raises(FormulaError, match="no value for 'z'"):
        Formula.parse("z + 1").evaluate({})


def test_find_gaps_reports_a_common_stall_once():
    t = np.arange(0, 20, 0.02)
    stall = (t > 8.0) & (t < 10.0)
    a = np.round(t[~stall] * 1e9).astype(np.int64)
    slow = np.arange(0, 20, 0.15)
    b = np.round(slow[(slow <= 8.0) | (slow >= 10.0)] * 1e9).astype(np.int64)
    c = np.round(t[(t < 15.0) | (t > 15.4)] * 1e9).astype(np.int64)  # 0.4 s: below 0.5 s
    d = np.round(t[(t < 3.0) | (t > 4.0)] * 1e9).astype(np.int64)
    gaps = find_gaps({"a": a, "b": b, "c": c[~((c > 8e9) & (c < 10e9))], "d": d})
    assert [g.signals for g in gaps] == [("d",), ("a", "b", "c")]
    common = gaps[1]
    assert 7.98 <= common.t0_ns * 1e-9 <= 8.0
    assert 10.0 <= common.t1_ns * 1e-9 <= 10.02
    assert common.span_ns[0] <= common.t0_ns
    assert common.span_ns[1] >= common.t1_ns
    assert common.to_dict()["signals"] == ["a", "b", "c"]
    assert find_gaps({"a": a}, min_gap_s=3.0) == []
