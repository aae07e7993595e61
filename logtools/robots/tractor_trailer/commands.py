"""The tractor-trailer's commands: ``logcal simulate tractor-trailer`` (a simulated drive log with
known truth, LOG_FORMAT.md) and ``logcal reproduce patent`` (the patent's Figs. 8-13 recomputed
beside the published numbers). Named by the plugin (``simulate``/``reproduce``) and imported
when the CLI is built.

The library (:mod:`calib.tractor_trailer.sim`) decides which parameters make physical sense; this
module only translates its :class:`~calib.tractor_trailer.sim.validation.SimParameterError` into
the option's name.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Iterable
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console, Group, RenderableType
from rich.table import Table
from rich.text import Text

from calib.tractor_trailer.sim.choices import HitchModel, PresetName
from logtools.console import report_console
from logtools.writers.encoding import LogEncoding

if TYPE_CHECKING:
    from calib.tractor_trailer.reproduce import FigureCell, FigureTable, PatentReproduction
    from calib.tractor_trailer.sim.validation import SimParameterError
    from logtools.errors import LogcalInputError

__all__ = [
    "OPTION_OF_PARAMETER",
    "input_error",
    "register_reproduce",
    "register_simulate",
    "render_reproduction",
]

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


def register_simulate(group: typer.Typer) -> None:
    """Add ``tractor-trailer`` to the ``simulate`` group."""

    @group.command("tractor-trailer")
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
            n = write_atomically(out, lambda tmp: write_run(tmp, run, encoding=enc, metadata=meta))
        unit = "rows" if enc is LogEncoding.CSV else "messages"
        print(
            f"wrote {out} ({enc}): {n} {unit}, {cfg.commands.duration_s:g} s, "
            f"L1 = {L1:g} m, L2 = {L2:g} m, |kappa_cmd| <= {cfg.commands.peak_abs():.3g} 1/m, "
            f"seed {seed}"
        )


def register_reproduce(group: typer.Typer) -> None:
    """Add ``patent`` to the ``reproduce`` group."""

    @group.command("patent")
    def patent(
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        repeats: int = typer.Option(10, "--repeats", help="Noisy repeats (patent: 10)."),
        seed: int = typer.Option(0, "--seed", help="Seed of the simulated sensor noise."),
    ) -> None:
        """Recompute the patent's Figs. 8-13 beside the published numbers."""
        from calib.tractor_trailer.reproduce import reproduce_patent
        from logtools.errors import LogcalInputError

        if repeats < 1:
            raise LogcalInputError(f"--repeats {repeats}: expected a whole number >= 1")
        rep = reproduce_patent(repeats=repeats, seed=seed)
        if as_json:
            sys.stdout.write(json.dumps(rep.to_dict(), indent=1) + "\n")
        else:
            report_console(min_width=160).print(render_reproduction(rep))


_STATUS_STYLE = {"ok": "green", "outside": "bold red", "round-off": "yellow", "order": "yellow"}
_STATUS_MARK = {"ok": "", "outside": " ✗", "round-off": " ~", "order": " ≈"}


def _fmt_like(value: float, printed: str) -> str:
    """``value`` with the precision of the printed number (same decimals or exponent form)."""
    if value is None or not math.isfinite(value):
        return "-"
    mantissa, _, exponent = printed.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    text = f"{value:.{decimals}e}" if exponent else f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and not text.strip("-0.e+") else text


def _cell_texts(cell: FigureCell) -> tuple[Text, str, str]:
    p = cell.published
    ours = _fmt_like(cell.ours, p.printed)
    pub = p.printed
    if p.sigma is not None:
        ours += "±" + (_fmt_like(cell.ours_std, p.sigma) if math.isfinite(cell.ours_std) else "-")
        pub += "±" + p.sigma
    if p.misprint_of is not None:
        pub += f" (misprint of {p.misprint_of})"
    style = _STATUS_STYLE.get(cell.status, "")
    dev = "-" if not math.isfinite(cell.deviation) else f"{cell.deviation:+.3g}"
    return Text(ours + _STATUS_MARK.get(cell.status, ""), style=style), pub, dev


def _figure_table(fig: FigureTable) -> Table:
    counts = ", ".join(f"{k} {v}" for k, v in sorted(fig.counts().items()))
    table = Table(title=Text(f"Fig. {fig.figure}: {fig.title}  [{counts}]"), title_justify="left")
    amplitudes = sorted({c.published.M for c in fig.cells}, reverse=True)
    for col in ("cmd", "method", "quantity"):
        table.add_column(col)
    for M in amplitudes:
        for col in ("ours", "published", "dev"):
            table.add_column(f"{col} M={M}", justify="right")
    rows: dict[tuple[str, str, str], dict[float, FigureCell]] = {}
    for c in fig.cells:
        p = c.published
        rows.setdefault((p.cmd, p.method, p.quantity), {})[p.M] = c
    for (cmd, method, quantity), by_m in rows.items():
        cells: list[RenderableType] = [Text(cmd), Text(method), Text(quantity)]
        for M in amplitudes:
            cell = by_m.get(M)
            cells += list(_cell_texts(cell)) if cell is not None else ["", "", ""]
        table.add_row(*cells)
    return table


def _split_table(rep: PatentReproduction) -> Table:
    table = Table(title=Text(f"CLS weakness: {rep.split_setting}"), title_justify="left")
    for col in ("true L1", "true L2", "true L1/(L1+L2)", "method", "L1", "L2", "L1/(L1+L2)"):
        table.add_column(col, justify="left" if col == "method" else "right")
    for r in rep.split_rows:
        table.add_row(
            f"{r.L1_true:.3f}",
            f"{r.L2_true:.3f}",
            f"{r.L1_true / (r.L1_true + r.L2_true):.3f}",
            Text(r.method),
            f"{r.L1:.3f}",
            f"{r.L2:.3f}",
            Text(f"{r.split:.3f}", style="yellow"),
        )
    return table


def _notes(lines: Iterable[str]) -> Text:
    return Text("\n".join(f"• {n}" for n in lines), style="dim")


def render_reproduction(rep: PatentReproduction) -> RenderableType:
    """Rich tables of a ``PatentReproduction`` (ours | published | deviation, flags)."""
    parts: list[RenderableType] = [
        Text(
            f"Patent KR 10-1481896, Figs. 8-13 reproduced ({rep.repeats} noisy repeats, "
            f"seed {rep.seed}). ✗ outside the printed precision (ideal) or σ (noisy); "
            "~ round-off-level intercept; ≈ same order of magnitude (Fig. 9).",
            style="bold",
        )
    ]
    for fig in rep.figures:
        parts.append(_figure_table(fig))
        if fig.notes:
            parts.append(_notes(fig.notes))
    parts.append(_split_table(rep))
    parts.append(_notes(rep.notes))
    return Group(*parts)


def _status(message: str) -> AbstractContextManager[object]:
    """A spinner with ``message`` on stderr when it is a terminal, else nothing."""
    if not sys.stderr.isatty():
        return nullcontext()

    return Console(stderr=True).status(message, spinner="dots")
