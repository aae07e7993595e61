"""``logcal simulate``: write simulated drive logs with known truth (LOG_FORMAT.md).

``logcal simulate tractor-trailer --out FILE [--encoding json|ros2|csv] [--preset NAME] ...``
``logcal simulate samples [DIR]`` regenerates ``sample_logs/``.

The library (:mod:`calib.tractor_trailer.sim`) decides which parameters make physical sense; this
module only
translates its :class:`~calib.tractor_trailer.sim.validation.SimParameterError` into the option's
name.
"""

from __future__ import annotations

import sys
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from calib.manipulator.choices import Conceal
from calib.tractor_trailer.sim.choices import HitchModel, PresetName
from logtools.writers.encoding import LogEncoding

if TYPE_CHECKING:
    from calib.tractor_trailer.sim.validation import SimParameterError
    from logtools.errors import LogcalInputError

__all__ = ["OPTION_OF_PARAMETER", "input_error", "register"]

OPTION_OF_PARAMETER: dict[str, str] = {
    "L1": "--L1",
    "L2": "--L2",
    "v_mps": "--speed",
    "duration_s": "--duration",
    "noise_scale": "--noise-scale",
    "rate_hz": "--rate",
    "seed": "--seed",
    "actuator_delay_s": "--delay",
    "actuator_lag_s": "--lag",
    "understeer_K": "--understeer",
    "timestamp_jitter_s": "--jitter",
}
"""The ``tractor-trailer`` option that sets each simulator parameter."""


def input_error(err: SimParameterError) -> LogcalInputError:
    """``err`` as the CLI's one-line message: the option, the value given, what was expected."""
    from calib.tractor_trailer.sim.validation import show
    from logtools.errors import LogcalInputError

    names = [err.parameter, *err.related]
    if not all(name in OPTION_OF_PARAMETER for name in names):  # a preset's own value
        return LogcalInputError(str(err))
    given = ", ".join(f"{OPTION_OF_PARAMETER[k]} {show(v)}" for k, v in err.related.items())
    with_ = f" (with {given})" if given else ""
    option = OPTION_OF_PARAMETER[err.parameter]
    return LogcalInputError(f"{option} {show(err.value)}{with_}: expected {err.expected}")


def register(app: typer.Typer) -> None:
    """Add the ``simulate`` command group to ``app``."""
    sim = typer.Typer(
        name="simulate",
        help="Write simulated drive logs whose true parameters are in the 'logcal' metadata.",
        invoke_without_command=True,
        rich_markup_mode=None,
    )

    @sim.callback()
    def _group(ctx: typer.Context) -> None:
        if ctx.invoked_subcommand is None:  # bare ``logcal simulate``: its help, success
            typer.echo(ctx.get_help())
            raise typer.Exit(0)
    app.add_typer(sim, name="simulate")
    from logtools.cli.diff_drive import register_simulate as _diff_drive

    _diff_drive(sim)

    @sim.command("tractor-trailer")
    def tractor_trailer(
        out: Path = typer.Option(..., "--out", "-o", help="Output log file."),
        encoding: LogEncoding | None = typer.Option(
            None, "--encoding", help="Log encoding (default: csv for *.csv, else json)."
        ),
        preset: PresetName = typer.Option(
            PresetName.MIXED,
            "--preset",
            help="Command preset (0.2 1/m, lowered where the joint would pass 0.77 rad).",
        ),
        L1: float = typer.Option(
            1.25, "--L1", help="Link 1 length C1-P (m); 0 or negative: hitch ahead of the axle."
        ),
        L2: float = typer.Option(2.48, "--L2", help="Link 2 length P-C2 (m), > |L1|."),
        speed: float = typer.Option(1.0, "--speed", help="Forward speed of C1 (m/s), > 0."),
        duration: float | None = typer.Option(
            None,
            "--duration",
            help="Run length (s); default the preset's (63 / 249 s). Mixed repeats its cycle.",
        ),
        noise_scale: float = typer.Option(
            1.0, "--noise-scale", help="Factor >= 0 on the default sensor noise (0: none)."
        ),
        rate: float = typer.Option(50.0, "--rate", help="Base sampling rate (Hz); pose at half."),
        seed: int = typer.Option(0, "--seed", help="Seed (>= 0) of the sensor noise."),
        delay: float = typer.Option(0.0, "--delay", help="Actuator dead time (s)."),
        lag: float = typer.Option(0.0, "--lag", help="Actuator first-order lag (s)."),
        understeer: float = typer.Option(0.0, "--understeer", help="Understeer K (s^2/m^2)."),
        jitter: float = typer.Option(
            0.0,
            "--jitter",
            help="Std of timestamp jitter on every topic (s), below the sample period; "
            "stamps stay strictly increasing.",
        ),
        hitch_model: HitchModel = typer.Option(
            HitchModel.TRANSIENT, "--hitch-model", help="transient (real kinematics) | steady."
        ),
        include_effects: bool = typer.Option(
            False, "--include-effects", help="Also write injected effects into the metadata."
        ),
    ) -> None:
        """Simulate a tractor with an off-axle trailer and write its drive log."""
        from calib.tractor_trailer.sim.presets import preset as make_preset
        from calib.tractor_trailer.sim.tractor_trailer import Effects, simulate_tractor_trailer
        from calib.tractor_trailer.sim.validation import SimParameterError
        from logtools.outputs import check_output, write_atomically
        from logtools.writers.tractor_trailer import run_metadata, write_run

        check_output(out, option="--out", suffixes=(".mcap", ".csv"))
        enc = encoding or LogEncoding.for_path(out)
        kwargs: dict[str, object] = {
            "L1": L1,
            "L2": L2,
            "v_mps": speed,
            "noise_scale": noise_scale,
            "rate_hz": rate,
            "timestamp_jitter_s": jitter,
            "hitch_model": hitch_model,
        }
        if duration is not None:
            kwargs["duration_s"] = duration
        try:
            kwargs["effects"] = Effects(
                actuator_delay_s=delay, actuator_lag_s=lag, understeer_K=understeer
            )
            cfg = make_preset(preset, **kwargs)
            with _status(f"simulating {cfg.commands.duration_s:.0f} s"):
                run = simulate_tractor_trailer(cfg, seed=seed)
        except SimParameterError as err:
            raise input_error(err) from err
        with _status(f"writing {out}"):
            meta = run_metadata(run, include_effects=include_effects, extra={"preset": preset})
            n = write_atomically(
                out, lambda tmp: write_run(tmp, run, encoding=enc, metadata=meta)
            )
        unit = "rows" if enc is LogEncoding.CSV else "messages"
        print(
            f"wrote {out} ({enc}): {n} {unit}, {cfg.commands.duration_s:g} s, "
            f"L1 = {L1:g} m, L2 = {L2:g} m, |kappa_cmd| <= {cfg.commands.peak_abs():.3g} 1/m, "
            f"seed {seed}"
        )

    @sim.command("manipulator")
    def manipulator(
        out: Path = typer.Option(..., "--out", "-o", help="Output log file."),
        encoding: LogEncoding | None = typer.Option(
            None, "--encoding", help="Log encoding (default: csv for *.csv, else json)."
        ),
        arm: str = typer.Option(
            "planar2", "--arm", help="planar2 (the JKROS 2012 arm) or a URDF path / "
            "example-robot-data name (e.g. panda)."
        ),
        duration: float = typer.Option(20.0, "--duration", help="Run length (s), > 1."),
        rate: float | None = typer.Option(None, "--rate", help="Rate (Hz); default 500 / 1000."),
        seed: int = typer.Option(0, "--seed", help="Seed (>= 0) of the trajectory and noise."),
        torque_noise: float = typer.Option(0.05, "--torque-noise", help="Torque noise std (N·m)."),
        payload: float = typer.Option(0.0, "--payload", help="Held payload (kg), >= 0."),
        conceal: Conceal | None = typer.Option(
            None, "--conceal", help="Leave friction or payload out of the log's declared model."
        ),
    ) -> None:
        """Simulate a serial arm and write its /joint_states log (manipulator)."""
        from logtools.errors import LogcalInputError
        from logtools.outputs import check_output, write_atomically
        from logtools.writers.manipulator import write_simulated_arm

        check_output(out, option="--out", suffixes=(".mcap", ".csv"))
        if duration <= 1 or torque_noise < 0 or payload < 0 or seed < 0:
            raise LogcalInputError(
                f"--duration {duration:g} --torque-noise {torque_noise:g} --payload {payload:g} "
                f"--seed {seed}: expected duration > 1 s and non-negative noise, payload, seed"
            )
        from calib.errors import CalibError

        try:
            run, n = write_atomically(out, lambda tmp: write_simulated_arm(
                tmp, arm=arm, encoding=encoding or LogEncoding.for_path(out),
                duration_s=duration, rate_hz=rate, seed=seed, torque_noise=torque_noise,
                payload=payload, conceal=conceal,
            ))
        except CalibError as err:
            raise LogcalInputError(f"--arm {arm}: {err}") from err
        print(f"wrote {out}: {n} messages, {len(run.joint_names)} joints, {duration:g} s, "
              f"seed {seed}")

    @sim.command("samples")
    def samples(
        out_dir: Path = typer.Argument(Path("sample_logs"), help="Directory for the logs."),
    ) -> None:
        """Regenerate the sample logs (same as `python -m logtools.sample_logs DIR`)."""
        from logtools.sample_logs import write_sample_logs

        for path in write_sample_logs(out_dir):
            print(f"{path}  {path.stat().st_size / 1e6:.2f} MB")


def _status(message: str) -> AbstractContextManager[object]:
    """A spinner with ``message`` on stderr when it is a terminal, else nothing."""
    if not sys.stderr.isatty():
        return nullcontext()
    from rich.console import Console

    return Console(stderr=True).status(message, spinner="dots")
