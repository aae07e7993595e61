"""``logcal batch ARCHIVE --out DIR`` and ``logcal serve DIR``: batch reports over a log archive
(library: :mod:`logtools.batch`; docs/batch.md)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import typer

from logtools.batch.choices import Engine
from logtools.cli._inputs import end_option, start_option
from logtools.cli._robot_options import GivenOptions, with_robot_options

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``batch`` and ``serve`` commands to ``app``."""

    @app.command("batch")
    @with_robot_options("batch")
    def batch(
        archive: Path = typer.Argument(
            ...,
            help="Folder of logs (MCAP, CSV, ROS bags), with "
            "optional logcal.toml files (docs/batch.md).",
        ),
        out: Path = typer.Option(
            ..., "--out", "-o", help="Output folder (created; reruns resume in it)."
        ),
        engine: Engine = typer.Option(Engine.LOCAL, "--engine", help="local process pool or ray."),
        workers: int = typer.Option(
            2,
            "--workers",
            min=1,
            help="Worker processes (local), or CPUs of a new local Ray instance.",
        ),
        address: str | None = typer.Option(
            None, "--address", help="Address of a running Ray cluster (--engine ray)."
        ),
        repeats: int = typer.Option(10, "--repeats", min=1, help="Bootstrap repeats per method."),
        no_discovery: bool = typer.Option(False, "--no-discovery", help="Skip discovery."),
        no_views: bool = typer.Option(False, "--no-views", help="Do not draw .rrd/.png views."),
        seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap draws."),
        force: bool = typer.Option(False, "--force", help="Redo every log."),
        prune: bool = typer.Option(
            False,
            "--prune",
            help="Drop the records of logs gone from ARCHIVE (kept otherwise; never when "
            "ARCHIVE is empty or a folder of it cannot be listed).",
        ),
        start: float | None = start_option(),
        end: float | None = end_option(),
        log_memory: float | None = typer.Option(
            None,
            "--log-memory",
            min=0.0,
            metavar="GIB",
            help="Memory budget of one log: its worker's address space in GiB (0: none; "
            "default: 80% of RAM / workers, between 6 and 8 GiB).",
        ),
        log_timeout: float = typer.Option(
            3600.0,
            "--log-timeout",
            min=0.0,
            metavar="SECONDS",
            help="Time budget of one log (0: none).",
        ),
        *,
        robot_options: GivenOptions,
    ) -> None:
        """Analyse every log of ARCHIVE in parallel (resumable) and write fleet results and
        an HTML report to --out."""
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        from logtools.batch.budgets import Budgets
        from logtools.batch.runner import BatchProgress, run_batch
        from logtools.batch.worker import AnalysisOptions
        from logtools.safe_text import printable

        if address and engine is not Engine.RAY:
            raise typer.BadParameter("--address needs --engine ray", param_hint="--address")
        options = AnalysisOptions(
            repeats=repeats,
            seed=seed,
            discovery=not no_discovery,
            views=not no_views,
            start_s=start,
            end_s=end,
            options=robot_options.by_key(),
        )
        budgets = Budgets.from_flags(log_memory, log_timeout, workers)  # docs/batch.md#budgets
        # --start/--end crop each log as analyze does; robot options apply to every log
        err = Console(stderr=True)
        bar = Progress(
            TextColumn("[bold]analysing"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("[red]{task.fields[failed]} failed"),
            TextColumn("·"),
            TimeElapsedColumn(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            TextColumn("{task.fields[last]}", markup=False),
            console=err,
            transient=False,
            disable=not sys.stderr.isatty(),
        )
        task = bar.add_task("logs", total=None, failed=0, last="")

        def show(p: BatchProgress) -> None:
            bar.update(
                task, total=p.total, completed=p.done, failed=p.failed, last=printable(p.last)[-40:]
            )

        t0 = time.perf_counter()
        with bar:
            summary = run_batch(
                archive,
                out,
                options=options,
                engine=engine,
                workers=workers,
                address=address,
                force=force,
                progress=show,
                budgets=budgets,
                prune=prune,
            )
        err.print(
            f"{summary.logs} logs: {len(summary.analysed)} analysed, {len(summary.skipped)} "
            f"already done, {len(summary.failed)} failed; {time.perf_counter() - t0:.1f} s. "
            f"Report: {printable(summary.out / 'index.html')}",
            markup=False,
            highlight=False,
        )
        if summary.gone:
            err.print(
                f"{len(summary.gone)} record(s) kept whose log is gone from the archive "
                f"(e.g. {printable(summary.gone[0])}); --prune drops them.",
                markup=False,
                highlight=False,
            )
        if summary.pruned:
            err.print(
                f"{len(summary.pruned)} record(s) of logs gone from the archive dropped (--prune).",
                markup=False,
                highlight=False,
            )
        if summary.prune_refused:
            err.print(
                f"--prune: {printable(summary.prune_refused)}.", markup=False, highlight=False
            )
        for rel, message in summary.failed:  # names and messages from the archive: escaped
            err.print(
                f"  failed: {printable(rel)}: {printable(message)}",
                markup=False,
                highlight=False,
                soft_wrap=True,
            )

    @app.command("serve")
    def serve(
        out: Path = typer.Argument(..., help="The --out folder of `logcal batch`."),
        port: int = typer.Option(8000, "--port", min=0, max=65535, help="Port on 127.0.0.1."),
        no_viewer: bool = typer.Option(
            False, "--no-viewer", help="Do not start rerun's web viewer."
        ),
    ) -> None:
        """Serve a batch report on 127.0.0.1, with rerun's web viewer for each log's .rrd."""
        import signal

        from logtools.batch.serve import start_server

        def _stop(*_: object) -> None:
            raise KeyboardInterrupt  # SIGTERM: stop the viewer too, as on Ctrl-C

        signal.signal(signal.SIGTERM, _stop)
        server = start_server(out, port=port, viewer=not no_viewer)
        print(f"report: {server.url}", flush=True)
        print(f"rerun web viewer: {server.viewer_url or 'not running'}", flush=True)
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            pass
        finally:
            server.close()
