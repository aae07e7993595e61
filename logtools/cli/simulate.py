"""``logcal simulate``: write simulated drive logs with known truth (LOG_FORMAT.md).

``logcal simulate tractor-trailer --out FILE [--encoding json|ros2|csv] [--preset NAME] ...``
``logcal simulate samples [DIR]`` regenerates ``sample_logs/``.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``simulate`` command group to ``app``."""
    sim = typer.Typer(
        name="simulate",
        help="Write simulated drive logs whose true parameters are in the 'logcal' metadata.",
        no_args_is_help=True,
    )
    app.add_typer(sim, name="simulate")

    @sim.command("tractor-trailer")
    def tractor_trailer(
        out: Path = typer.Option(..., "--out", "-o", help="Output log file."),
        encoding: str | None = typer.Option(
            None, "--encoding", help="json | ros2 | csv (default: csv for *.csv, else json)."
        ),
        preset: str = typer.Option("mixed", "--preset", help="harmonic | mixed."),
        L1: float = typer.Option(1.25, "--L1", help="Link 1 length C1-P (m)."),
        L2: float = typer.Option(2.48, "--L2", help="Link 2 length P-C2 (m)."),
        speed: float = typer.Option(1.0, "--speed", help="Forward speed of C1 (m/s)."),
        duration: float | None = typer.Option(
            None, "--duration", help="Run length (s); default the preset's (63 / 249 s)."
        ),
        noise_scale: float = typer.Option(
            1.0, "--noise-scale", min=0.0, help="Factor on the default sensor noise (0: none)."
        ),
        rate: float = typer.Option(50.0, "--rate", help="Base sampling rate (Hz)."),
        seed: int = typer.Option(0, "--seed", help="Seed of the sensor noise."),
        delay: float = typer.Option(0.0, "--delay", help="Actuator dead time (s)."),
        lag: float = typer.Option(0.0, "--lag", help="Actuator first-order lag (s)."),
        understeer: float = typer.Option(0.0, "--understeer", help="Understeer K (s^2/m^2)."),
        jitter: float = typer.Option(0.0, "--jitter", help="Timestamp jitter std (s)."),
        hitch_model: str = typer.Option(
            "transient", "--hitch-model", help="transient (real kinematics) | steady."
        ),
        include_effects: bool = typer.Option(
            False, "--include-effects", help="Also write injected effects into the metadata."
        ),
    ) -> None:
        """Simulate a tractor with an off-axle trailer and write its drive log."""
        from rich.console import Console

        from calib.sim.presets import preset as make_preset
        from calib.sim.tractor_trailer import Effects, simulate_tractor_trailer
        from logtools.errors import LogcalInputError
        from logtools.writers.tractor_trailer import ENCODINGS, run_metadata, write_run

        enc = encoding or ("csv" if out.suffix.lower() == ".csv" else "json")
        if enc not in ENCODINGS:
            raise LogcalInputError(f"--encoding {enc!r}: expected one of {', '.join(ENCODINGS)}")
        if hitch_model not in ("transient", "steady"):
            raise LogcalInputError(f"--hitch-model {hitch_model!r}: expected transient or steady")
        effects = Effects(actuator_delay_s=delay, actuator_lag_s=lag, understeer_K=understeer)
        kwargs: dict[str, object] = {
            "L1": L1,
            "L2": L2,
            "v_mps": speed,
            "noise_scale": noise_scale,
            "rate_hz": rate,
            "effects": effects,
        }
        if duration is not None:
            kwargs["duration_s"] = duration
        try:
            cfg = make_preset(preset, **kwargs)
        except ValueError as err:
            raise LogcalInputError(f"--preset: {err}") from err
        cfg = replace(cfg, timestamp_jitter_s=jitter, hitch_model=hitch_model)  # type: ignore[arg-type]
        err_console = Console(stderr=True)
        if sys.stderr.isatty():
            with err_console.status(f"simulating {cfg.commands.duration_s:.0f} s", spinner="dots"):
                run = simulate_tractor_trailer(cfg, seed=seed)
            with err_console.status(f"writing {out}", spinner="dots"):
                meta = run_metadata(run, include_effects=include_effects, extra={"preset": preset})
                n = write_run(out, run, encoding=enc, metadata=meta)  # type: ignore[arg-type]
        else:
            run = simulate_tractor_trailer(cfg, seed=seed)
            meta = run_metadata(run, include_effects=include_effects, extra={"preset": preset})
            n = write_run(out, run, encoding=enc, metadata=meta)  # type: ignore[arg-type]
        unit = "rows" if enc == "csv" else "messages"
        print(
            f"wrote {out} ({enc}): {n} {unit}, {cfg.commands.duration_s:g} s, "
            f"L1 = {L1:g} m, L2 = {L2:g} m, seed {seed}"
        )

    @sim.command("samples")
    def samples(
        out_dir: Path = typer.Argument(Path("sample_logs"), help="Directory for the logs."),
    ) -> None:
        """Regenerate the sample logs (same as `python -m logtools.sample_logs DIR`)."""
        from logtools.sample_logs import write_sample_logs

        for path in write_sample_logs(out_dir):
            print(f"{path}  {path.stat().st_size / 1e6:.2f} MB")
