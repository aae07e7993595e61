"""A fourth robot, defined entirely here, joins with one registration line: a kinematic bicycle
(car-like robot) whose wheelbase is found from its steering angle, speed and yaw rate
(omega = v tan(steer) / L).

It brings its signals, identification, analysis (least-squares wheelbase with an interval and a
``calib.adequacy`` verdict), report, rerun views, a ``simulate bicycle`` command, its sample log and
typed options (``--wheelbase-guess``), and then ``info`` recognises its logs, ``analyze`` (text
and JSON) and ``view`` go through it, ``simulate samples`` writes its sample beside the other
robots', and its options are on the command line and in the typed configuration, with nothing
robot-specific written anywhere else.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import typer
from rich.console import RenderableType
from rich.text import Text

import logtools.robots as robots
from calib.adequacy import ResidualChannel, assess
from calib.results import AnalysisResult, CalibrationResult, Estimate, StageStatus
from logtools.analyze import AnalysisConfig, options_from_settings
from logtools.cli.main import main
from logtools.errors import LogcalInputError
from logtools.load import LoadedLog
from logtools.robot_options import RobotOptions, build_options, option, option_specs
from logtools.robots import RobotPlugin, SignalSpec

MODULE = __name__  # the plugin names its views and commands by import path, like any robot
TRUE_WHEELBASE = 2.7
MIN_SPEED = 0.5  # m/s: below this the yaw rate says little about the wheelbase


# ------------------------------------------------------------------------- the robot's room


@dataclass(frozen=True)
class BicycleOptions(RobotOptions):
    """The bicycle's own options."""

    wheelbase_guess: float | None = option(
        flag="--wheelbase-guess",
        metavar="METRES",
        above=0.0,
        view=True,
        help="The wheelbase you expect (m); the report and views compare the estimate with it.",
    )


def _identify(found: frozenset[str]) -> str | None:
    if {"steer", "v", "omega"} <= found and "psi" not in found:
        return "signals steer, v, omega (no trailer angle)"
    return None


def _analyze(loaded: LoadedLog, config: AnalysisConfig, progress: object) -> AnalysisResult:
    frame = loaded.frame
    t = (frame["t_ns"].to_numpy() - int(frame["t_ns"][0])) * 1e-9
    steer, v, omega = (frame[c].to_numpy().astype(float) for c in ("steer", "v", "omega"))
    keep = np.isfinite(steer) & np.isfinite(v) & np.isfinite(omega) & (np.abs(v) > MIN_SPEED)
    x, y = v[keep] * np.tan(steer[keep]), omega[keep]
    sxx = float(x @ x)
    k = float(x @ y) / sxx  # omega = k v tan(steer), k = 1 / L
    residual = y - k * x
    n = int(keep.sum())
    k_std = math.sqrt(float(residual @ residual) / (n - 1) / sxx)
    wheelbase, std = 1.0 / k, k_std / k**2
    ci = (1.0 / (k + 1.96 * k_std), 1.0 / (k - 1.96 * k_std))
    adequacy = assess(
        [ResidualChannel("omega", "rad/s", t[keep], residual, measured=y)],
        model="kinematic bicycle",
    )
    est = Estimate("wheelbase", wheelbase, std, ci, unit="m")
    guess = config.options(BicycleOptions).wheelbase_guess  # the typed accessor
    verdict = f"wheelbase from {n} samples above {MIN_SPEED} m/s"
    return AnalysisResult(
        robot="bicycle",
        segments=[],
        methods=[],
        estimate=CalibrationResult("least squares", {"wheelbase": est}, verdict),
        adequacy=adequacy,
        source={"path": str(loaded.path)},
        stages=[StageStatus("wheelbase", "ok"), StageStatus("model adequacy", "ok")],
        sections={"samples_used": n, "wheelbase_guess": guess},
        artifacts={"t": t[keep], "omega": y, "predicted": k * x},
    )


def _report(result: AnalysisResult) -> list[RenderableType]:
    guess = result.sections["wheelbase_guess"]
    lines: list[RenderableType] = [Text(f"bicycle: {result.sections['samples_used']} samples used")]
    if guess is not None and result.estimate is not None:
        off = result.estimate.parameters["wheelbase"].value - guess
        lines.append(Text(f"estimate - your guess {guess:g} m: {off:+.3f} m"))
    return lines


seen_options: list[RobotOptions] = []


def bicycle_views(
    out: Path, loaded: LoadedLog, result: AnalysisResult, options: BicycleOptions
) -> Path:
    """The bicycle's rerun recording: measured and predicted yaw rate, and the estimate."""
    import rerun as rr

    seen_options.append(options)
    art = result.artifacts
    rec = rr.RecordingStream("logcal_bicycle")
    rec.save(out)
    try:
        times = rr.TimeColumn("time", duration=np.asarray(art["t"], float))
        rec.send_columns(
            "yaw_rate/measured",
            indexes=[times],
            columns=rr.Scalars.columns(scalars=np.asarray(art["omega"], float)),
        )
        rec.send_columns(
            "yaw_rate/predicted",
            indexes=[times],
            columns=rr.Scalars.columns(scalars=np.asarray(art["predicted"], float)),
        )
        text = result.estimate.report() if result.estimate is not None else "no estimate"
        if options.wheelbase_guess is not None:
            text += f"\n\nyour guess: {options.wheelbase_guess:g} m"
        rec.log("estimate", rr.TextDocument(text), static=True)
    finally:
        rec.flush()
        rec.disconnect()
    return out


def simulated_csv(wheelbase: float, duration: float, rate: float, seed: int) -> tuple[str, int]:
    """A kinematic bicycle's CSV drive log (text) and its number of rows."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / rate)
    v = 3.0 + 2.0 * np.sin(0.21 * t)
    steer = 0.3 * np.sin(0.5 * t) + 0.1 * np.sin(1.3 * t + 0.4)
    omega = v * np.tan(steer) / wheelbase + rng.normal(0.0, 0.005, t.size)
    rows = "\n".join(
        f"{a:.4f},{s:.6f},{b:.5f},{w:.6f}" for a, s, b, w in zip(t, steer, v, omega, strict=True)
    )
    return "t,steer,v,omega\n" + rows + "\n", int(t.size)


def write_samples(out_dir: Path) -> list[Path]:
    """The bicycle's sample log (``RobotPlugin.samples``): a fixed seed, the same bytes."""
    path = out_dir / "bicycle.csv"
    path.write_text(simulated_csv(TRUE_WHEELBASE, 30.0, 50.0, seed=1)[0])
    return [path]


def register_simulate(group: typer.Typer) -> None:
    """Add ``bicycle`` to ``logcal simulate``."""

    @group.command("bicycle")
    def bicycle(
        out: Path = typer.Option(..., "--out", "-o", help="Output CSV log."),
        wheelbase: float = typer.Option(TRUE_WHEELBASE, "--wheelbase", help="True L (m), > 0."),
        duration: float = typer.Option(60.0, "--duration", help="Run length (s)."),
        rate: float = typer.Option(50.0, "--rate", help="Sampling rate (Hz)."),
        seed: int = typer.Option(0, "--seed", help="Seed of the sensor noise."),
    ) -> None:
        """Simulate a kinematic bicycle and write its CSV drive log."""
        if wheelbase <= 0 or duration <= 1 or rate <= 0:
            raise LogcalInputError(
                f"--wheelbase {wheelbase:g} --duration {duration:g} --rate "
                f"{rate:g}: expected positive values, duration > 1 s"
            )
        text, rows = simulated_csv(wheelbase, duration, rate, seed)
        out.write_text(text)
        print(f"wrote {out}: {rows} rows, wheelbase {wheelbase:g} m, seed {seed}")


PLUGIN = RobotPlugin(
    name="bicycle",
    title="kinematic bicycle (car-like robot)",
    signals=(
        SignalSpec("steer", "rad", "front-wheel steering angle", required=True),
        SignalSpec("v", "m/s", "rear-axle speed", required=True),
        SignalSpec("omega", "rad/s", "yaw rate", required=True),
    ),
    identify=_identify,
    analyze=_analyze,
    report=_report,
    views=f"{MODULE}:bicycle_views",
    options=BicycleOptions,
    simulate=f"{MODULE}:register_simulate",
    samples=f"{MODULE}:write_samples",
)


# ------------------------------------------------------------------------------- the checks


@pytest.fixture
def bicycle() -> Iterator[None]:
    saved = list(robots._registered)
    robots.register(PLUGIN)  # the one registration line
    seen_options.clear()
    yield
    robots._registered[:] = saved


@pytest.fixture
def log(bicycle: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    out = tmp_path / "drive.csv"
    assert main(["simulate", "bicycle", "--out", str(out), "--seed", "3"]) == 0  # simulated
    assert f"wrote {out}" in capsys.readouterr().out
    return out


def test_recognised_by_info(log: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(log)]) == 0
    out = capsys.readouterr().out
    assert "robot: bicycle (signals steer, v, omega (no trailer angle))" in out


def test_analysed_with_an_interval_and_a_verdict(
    log: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["analyze", str(log), "--json", "--wheelbase-guess", "2.5"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "bicycle"
    wb = doc["estimate"]["wheelbase"]
    assert wb["ci95"][0] < TRUE_WHEELBASE < wb["ci95"][1]
    assert wb["value"] == pytest.approx(TRUE_WHEELBASE, rel=0.02)
    assert doc["adequacy"]["verdict"] == "explains"
    assert doc["wheelbase_guess"] == 2.5  # the CLI's option reached the analysis, typed
    assert doc["warnings"] == []


def test_reported(log: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["analyze", str(log), "--methods", "--wheelbase-guess", "2.5"]) == 0
    text = capsys.readouterr().out
    assert "bicycle:" in text
    assert "samples used" in text
    assert "wheelbase = 2.7" in text
    assert "your guess 2.5 m" in text


def test_viewed(log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rrd = tmp_path / "drive.rrd"
    assert (
        main(["view", str(log), "--no-viewer", "--rrd", str(rrd), "--wheelbase-guess", "2.6"]) == 0
    )
    assert rrd.is_file()
    assert rrd.stat().st_size > 0
    assert f"rerun recording saved: {rrd}" in capsys.readouterr().err
    assert seen_options == [BicycleOptions(wheelbase_guess=2.6)]  # typed, to the views
    again = tmp_path / "again.rrd"
    assert main(["analyze", str(log), "--rrd", str(again)]) == 0  # analyze --rrd: same views
    assert again.is_file()
    assert seen_options[-1] == BicycleOptions()


def test_samples_beside_the_other_robots(
    bicycle: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from logtools.robots.tractor_trailer.samples import SAMPLES

    out = tmp_path / "samples"
    assert main(["simulate", "samples", str(out)]) == 0  # every robot's declared samples
    printed = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [*(s.name for s in SAMPLES), "bicycle.csv"]
    )
    assert str(out / "bicycle.csv") in printed
    first = (out / "bicycle.csv").read_bytes()
    assert write_samples(tmp_path) == [tmp_path / "bicycle.csv"]
    assert (tmp_path / "bicycle.csv").read_bytes() == first  # the same bytes on every run
    assert main(["info", str(out / "bicycle.csv")]) == 0
    assert "robot: bicycle" in capsys.readouterr().out


def test_options_on_the_command_line(log: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for command in ("analyze", "view"):
        assert main([command, "-h"]) == 0
        assert "--wheelbase-guess METRES" in capsys.readouterr().out, command
    assert main(["simulate", "-h"]) == 0
    assert "bicycle" in capsys.readouterr().out
    assert main(["analyze", str(log), "--wheelbase-guess", "-1"]) == 2
    err = capsys.readouterr().err
    assert "--wheelbase-guess -1" in err
    assert "expected a number > 0" in err
    # another robot's option is warned about (from its declaration), not silently dropped
    assert main(["analyze", str(log), "--json", "--urdf", "panda"]) == 0
    captured = capsys.readouterr()
    assert "--urdf applies to manipulator logs" in captured.err
    assert "bicycle log" in captured.err
    assert any("--urdf applies" in w for w in json.loads(captured.out)["warnings"])


def test_options_are_typed_in_the_configuration(bicycle: None) -> None:
    specs = option_specs(PLUGIN)
    assert [(s.key, s.flag, s.view, s.type) for s in specs] == [
        ("wheelbase_guess", "--wheelbase-guess", True, float)
    ]
    cfg = AnalysisConfig(robot_options=options_from_settings({"wheelbase_guess": 2.5}))
    assert cfg.options(BicycleOptions) == BicycleOptions(wheelbase_guess=2.5)
    assert AnalysisConfig().options(BicycleOptions) == BicycleOptions()
    with pytest.raises(
        LogcalInputError,
        match=r"logcal.toml: wheelbase_guess = 'long': "
        r"expected a number > 0",
    ):
        build_options(BicycleOptions, {"wheelbase_guess": "long"}, where="logcal.toml")
    with pytest.raises(LogcalInputError, match="'wheel_base' is not an option of any robot"):
        options_from_settings({"wheel_base": 2.5})


def test_batch_settings_take_the_robots_options(log: Path, tmp_path: Path) -> None:
    import re

    from logtools.batch.archive import find_logs
    from logtools.batch.settings import SettingsError, settings_for
    from logtools.batch.worker import AnalysisOptions, analyse_job

    archive = tmp_path / "archive"
    (archive / "car").mkdir(parents=True)
    run = archive / "car" / "drive.csv"
    run.write_bytes(log.read_bytes())
    (archive / "logcal.toml").write_text('robot = "bicycle"\nwheelbase_guess = 2.5\n')
    settings = settings_for(archive, run)  # the bicycle's key, from its declaration
    carried = [v for v in vars(settings).values() if isinstance(v, Mapping)]
    assert any(BicycleOptions(wheelbase_guess=2.5) in m.values() for m in carried)
    # the worker builds the typed options from the settings: the analysis and views get them
    [job] = find_logs(archive)
    outcome = analyse_job(job, AnalysisOptions(repeats=1, discovery=False, views=True))
    assert outcome.status == "ok", outcome.error
    assert outcome.result is not None
    assert outcome.result["wheelbase_guess"] == 2.5
    assert seen_options == [BicycleOptions(wheelbase_guess=2.5)]
    assert outcome.views[".rrd"]
    assert any("no report image" in n for n in outcome.notes)
    again = settings_for(archive, run)
    (archive / "car" / "logcal.toml").write_text("wheelbase_guess = 2.6\n")  # nearest wins
    assert settings_for(archive, run).robot_options == {
        "bicycle": BicycleOptions(wheelbase_guess=2.6)
    }
    assert settings_for(archive, run).fingerprint != again.fingerprint  # a changed option
    (archive / "car" / "logcal.toml").write_text('wheelbase_guess = "long"\n')
    toml = archive / "car" / "logcal.toml"
    with pytest.raises(
        SettingsError, match=re.escape(f"{toml}: wheelbase_guess = 'long': expected a number > 0")
    ):
        settings_for(archive, run)
