"""`logcal simulate`: in-process through main(argv), and once end to end as a subprocess."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from logtools.cli.main import main
from logtools.readers import read_log


@pytest.mark.parametrize(
    ("name", "encoding", "topic"),
    [("a.mcap", "json", "/odom"), ("b.mcap", "ros2", "/odom"), ("c.csv", None, "csv")],
)
def test_simulate_writes_each_encoding(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, encoding: str | None, topic: str
) -> None:
    out = tmp_path / name
    args = ["simulate", "tractor-trailer", "--out", str(out), "--preset", "harmonic"]
    args += ["--duration", "5", "--rate", "20", "--L1", "0.9", "--L2", "3.1", "--seed", "4"]
    if encoding:
        args += ["--encoding", encoding]
    assert main(args) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    log = read_log(out)
    assert log.topics[topic].height == 101
    if topic != "csv":
        meta = log.metadata["logcal"]
        assert (meta["L1"], meta["L2"], meta["seed"], meta["preset"]) == (
            "0.9",
            "3.1",
            "4",
            "harmonic",
        )


def test_effects_in_metadata_only_when_asked(tmp_path: Path) -> None:
    base = ["simulate", "tractor-trailer", "--duration", "3", "--delay", "0.3", "--lag", "0.2"]
    assert main([*base, "--out", str(tmp_path / "h.mcap")]) == 0
    assert main([*base, "--out", str(tmp_path / "s.mcap"), "--include-effects"]) == 0
    hidden = read_log(tmp_path / "h.mcap").metadata["logcal"]
    shown = read_log(tmp_path / "s.mcap").metadata["logcal"]
    assert "actuator_delay_s" not in hidden
    assert (shown["actuator_delay_s"], shown["actuator_lag_s"]) == ("0.3", "0.2")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--preset", "nope"], "Invalid value for '--preset': "),
        (["--encoding", "xml"], "Invalid value for '--encoding': "),
        (["--hitch-model", "wobbly"], "Invalid value for '--hitch-model': "),
    ],
)
def test_bad_options_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    args = ["simulate", "tractor-trailer", "--out", str(tmp_path / "x.mcap"), *extra]
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_unwritable_out_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "missing" / "x.mcap"
    assert main(["simulate", "tractor-trailer", "--duration", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err
    assert "does not exist" in err


def test_simulate_end_to_end_subprocess(tmp_path: Path) -> None:
    out = tmp_path / "e.mcap"
    cmd = [sys.executable, "-c", "from logtools.cli.main import run; run()"]  # = `logcal`
    proc = subprocess.run(
        [*cmd, "simulate", "tractor-trailer", "--out", str(out), "--duration", "4"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # no progress output when stderr is not a terminal
    assert read_log(out).metadata["logcal"]["robot"] == "tractor_trailer"
