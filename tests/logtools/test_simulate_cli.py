"""`logcal simulate tractor-trailer`: parameters without physical sense exit 2 with one message
naming the option; coarse rates, jitter and a negative L1 work."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from logtools.cli.main import main
from logtools.readers import read_log

BASE = ["simulate", "tractor-trailer", "--preset", "harmonic", "--duration", "4", "--rate", "10"]


def _run(tmp_path: Path, *extra: str) -> int:
    return main([*BASE, "--out", str(tmp_path / "x.mcap"), *extra])


@pytest.mark.parametrize(
    ("extra", "option"),
    [
        (["--rate", "0"], "--rate 0"),
        (["--rate", "-5"], "--rate -5"),
        (["--rate", "nan"], "--rate nan"),
        (["--rate", "0.1"], "--rate 0.1"),  # coarser than the trailer's dynamics
        (["--L2", "0"], "--L2 0"),
        (["--L2", "-2"], "--L2 -2"),
        (["--L2", "inf"], "--L2 inf"),
        (["--L1", "nan"], "--L1 nan"),
        (["--L1", "3"], "--L1 3 (with --L2 2.48)"),  # |L1| >= L2
        (["--L1", "-2.5"], "--L1 -2.5 (with --L2 2.48)"),
        (["--duration", "-5"], "--duration -5"),
        (["--duration", "0"], "--duration 0"),
        (["--duration", "inf"], "--duration inf"),
        (["--duration", "0.1"], "--duration 0.1"),  # fewer than two pose samples
        (["--speed", "inf"], "--speed inf"),
        (["--speed", "nan"], "--speed nan"),
        (["--speed", "0"], "--speed 0"),
        (["--speed", "-1"], "--speed -1"),
        (["--noise-scale", "-0.5"], "--noise-scale -0.5"),
        (["--noise-scale", "nan"], "--noise-scale nan"),
        (["--jitter", "-0.001"], "--jitter -0.001"),
        (["--jitter", "0.1"], "--jitter 0.1"),  # = the sample period at 10 Hz
        (["--jitter", "nan"], "--jitter nan"),
        (["--delay", "-0.1"], "--delay -0.1"),
        (["--lag", "inf"], "--lag inf"),
        (["--understeer", "-2"], "--understeer -2"),  # 1 + K v^2 <= 0
        (["--understeer", "nan"], "--understeer nan"),
        (["--seed", "-1"], "--seed -1"),
    ],
)
def test_bad_parameter_exits_2_with_one_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], option: str
) -> None:
    assert _run(tmp_path, *extra) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith(f"logcal: error: {option}: expected "), err
    assert len(err.splitlines()) == 1
    assert "Traceback" not in err
    assert captured.out == ""
    assert not (tmp_path / "x.mcap").exists()


@pytest.mark.parametrize(
    ("extra", "option"),
    [
        (["--preset", "nope"], "'--preset'"),
        (["--encoding", "xml"], "'--encoding'"),
        (["--hitch-model", "wobbly"], "'--hitch-model'"),
    ],
)
def test_bad_choice_exits_2_naming_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], option: str
) -> None:
    assert _run(tmp_path, *extra) == 2
    err = capsys.readouterr().err
    assert f"Invalid value for {option}: " in err
    assert "Traceback" not in err


def test_negative_l1_accepted(tmp_path: Path) -> None:
    assert _run(tmp_path, "--L1", "-0.02", "--L2", "0.5") == 0
    meta = read_log(tmp_path / "x.mcap").metadata["logcal"]
    assert (meta["L1"], meta["L2"]) == ("-0.02", "0.5")
    assert _run(tmp_path, "--L1", "0") == 0


def test_long_trailer_gets_a_gentler_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The preset's 0.2 1/m would turn a 9 m trailer past its steady-turn limit: the command is
    lowered so the joint stays below 0.77 rad, and the CLI says how far it goes."""
    assert _run(tmp_path, "--L2", "9") == 0
    assert "|kappa_cmd| <= 0.0703 1/m" in capsys.readouterr().out
    assert _run(tmp_path) == 0
    assert "|kappa_cmd| <= 0.2 1/m" in capsys.readouterr().out


def test_coarse_rate_with_jitter_keeps_stamps_increasing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "r10.mcap"
    args = ["simulate", "tractor-trailer", "--rate", "10", "--jitter", "0.01", "--out", str(out)]
    assert main([*args, "--duration", "60"]) == 0
    assert "wrote" in capsys.readouterr().out
    stamps: dict[str, list[int]] = defaultdict(list)
    with out.open("rb") as fh:
        for _, channel, message in make_reader(fh).iter_messages(log_time_order=False):
            stamps[channel.topic].append(message.log_time)
    assert set(stamps) == {"/cmd/curvature", "/cmd/vel", "/odom", "/pose", "/hitch/angle"}
    for topic, t in stamps.items():
        d = np.diff(np.asarray(t))
        assert np.all(d > 0), topic
    jittered = np.diff(np.asarray(stamps["/odom"])) * 1e-9
    assert np.std(jittered) > 0.005  # the jitter is there: diffs spread around 0.1 s
    assert np.mean(jittered) == pytest.approx(0.1, abs=0.005)


def test_default_jitter_at_default_rate(tmp_path: Path) -> None:
    assert _run(tmp_path, "--rate", "50", "--jitter", "0.01") == 0
