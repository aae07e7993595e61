"""Outputs never clobber an input and are checked before any work; text from a log never
reaches the terminal as control codes or markup."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from mcap.writer import Writer

from logtools.cli.main import main
from logtools.outputs import OutputPathError, check_output, write_atomically
from logtools.safe_text import printable

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_logs" / "tt_harmonic_clean.mcap"
HOSTILE = "/evil\x1b]0;pwned\x07\x1b[2J\n- forged line [/x] [bold]"


def test_printable_escapes_controls_and_keeps_text() -> None:
    assert printable("a\x1b[2Jb\nc\u202ed é") == "a\\x1b[2Jb\\nc\\u202ed é"
    assert printable("plain/topic") == "plain/topic"


@pytest.mark.parametrize(
    ("name", "why"),
    [("in.mcap", "ending in .rrd"), ("x.png", "ending in .rrd"), ("sub", "ending in .rrd")],
)
def test_bad_rrd_paths_are_refused_before_the_analysis(
    tmp_path: Path, name: str, why: str, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "in.mcap"
    shutil.copy(SAMPLE, log)
    (tmp_path / "sub").mkdir()
    before = log.read_bytes()
    assert main(["analyze", str(log), "--rrd", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err
    assert why in err
    assert "--rrd" in err
    assert log.read_bytes() == before


def test_an_output_inside_the_input_or_over_it_is_refused(tmp_path: Path) -> None:
    log = tmp_path / "bag"
    log.mkdir()
    with pytest.raises(OutputPathError, match="never overwrites an input"):
        check_output(log / "x.rrd", option="--rrd", suffixes=(".rrd",), inputs=[log])
    same = tmp_path / "r.rrd"
    same.write_bytes(b"x")
    with pytest.raises(OutputPathError) as info:
        check_output(same, option="--rrd", suffixes=(".rrd",), inputs=[same])
    assert info.value.option == "--rrd"
    assert info.value.path == same
    with pytest.raises(OutputPathError, match="does not exist"):
        check_output(tmp_path / "no" / "x.rrd", option="--rrd", suffixes=(".rrd",))


def test_a_failed_write_leaves_neither_a_partial_nor_a_changed_file(tmp_path: Path) -> None:
    out = tmp_path / "r.rrd"
    out.write_bytes(b"old")

    def boom(tmp: Path) -> None:
        tmp.write_bytes(b"half")
        raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError):
        write_atomically(out, boom)
    assert out.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.rrd"]


def _hostile_log(path: Path) -> None:
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        schema = w.register_schema("std_msgs/Float64" + HOSTILE, "jsonschema", b"{}")
        hitch = w.register_channel("/hitch/angle", "json", schema)
        evil = w.register_channel(HOSTILE, "json", schema)
        for i in range(300):
            t = 1_000_000_000 + i * 20_000_000
            w.add_message(hitch, t, json.dumps({"data": 0.01 * (i % 7)}).encode(), t)
            w.add_message(evil, t, json.dumps({"data": 1.0}).encode(), t)
        w.add_metadata("site" + HOSTILE, {"k" + HOSTILE: "v" + HOSTILE})
        w.finish()


def test_hostile_names_are_escaped_in_info_and_analyze(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "a[" / "x]b"
    folder.mkdir(parents=True)
    log = folder / "evil.mcap"
    _hostile_log(log)
    assert main(["info", str(log)]) == 0
    assert main(["analyze", str(log), "--no-discovery", "--repeats", "1"]) in (0, 2)
    out = capsys.readouterr()
    assert "internal error" not in out.err
    text = out.out + out.err
    assert "\x1b" not in text
    assert "\x07" not in text
    assert "\n- forged line" not in text
    assert "\\x1b]0;pwned" in text  # shown, visibly escaped


def test_a_broken_ros2_schema_prints_nothing_of_its_own(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """mcap_ros2's schema parser prints the offending line (bytes from the log) to stderr
    before raising; logcal keeps that off the terminal and reports the topic cleanly."""
    from logtools.readers import read_log

    path = tmp_path / "bad_schema.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema(
            "std_msgs/msg/Float64", "ros2msg", b"float64 data\n\x1b]0;pwned\x07 bad line here\n"
        )
        ch = w.register_channel("/hitch/angle", "cdr", sid)
        for i in range(5):
            w.add_message(ch, i * 1000, b"\x00\x01\x00\x00" + bytes(8), i * 1000)
        w.finish()
    log = read_log(path)
    err = capsys.readouterr().err
    assert "pwned" not in err
    assert any("/hitch/angle" in str(p) for p in log.problems)


@pytest.mark.parametrize("robot", ["tractor-trailer", "diff-drive", "manipulator"])
def test_every_simulate_checks_its_output_before_simulating(
    robot: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", robot, "--out", str(tmp_path / "no" / "x.mcap")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["simulate", robot, "--out", str(tmp_path / "x.rrd")]) == 2
    assert "ending in .mcap or .csv" in capsys.readouterr().err
