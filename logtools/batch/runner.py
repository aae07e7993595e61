"""``logcal batch``: analyse every log of an archive, resumably, then write the fleet outputs.

The output folder holds::

    manifest.json          every log: content hash, settings key, status, time taken
    logs/<id>.json         per log: its settings, status, error or AnalysisResult JSON
    views/<id>.rrd, .png   per log: rerun recording and static image (when its robot has them)
    fleet.parquet          the fleet table (logtools.batch.table)
    fleet.json             pooled estimates and drift per robot and parameter
    index.html, pages/     the HTML report (logtools.batch.report_html)

Resuming: a log is analysed again only when its manifest entry is missing, its key (content
hash, logcal.toml settings and the files they name, analysis options, logcal version) differs,
or one of its output files is gone; ``force`` redoes all. Every file is written to a temporary
name and renamed over its target (``os.replace``), the manifest last, after each log: a batch
killed at any moment leaves whole files only, and its finished logs are not redone. Leftover
temporary files are removed at the next run. A lock file keeps two batches from writing one
folder at once.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from logtools.batch.archive import LogJob, find_logs
from logtools.batch.engines import Engine, run_jobs
from logtools.batch.worker import AnalysisOptions, LogOutcome
from logtools.errors import LogcalInputError

__all__ = ["BatchProgress", "BatchSummary", "read_records", "run_batch", "write_atomic"]

MANIFEST = "manifest.json"
FORMAT = "logcal-batch/1"


@dataclass
class BatchProgress:
    """Where a batch stands (passed to the progress callback after each log).

    ``total``: logs to analyse in this run (skipped ones excluded); ``done``: of those, finished
    (``failed`` included); ``skipped``: finished by an earlier run; ``last``: the log just done.
    """

    total: int
    done: int = 0
    failed: int = 0
    skipped: int = 0
    last: str = ""


@dataclass(frozen=True)
class BatchSummary:
    """What a batch did. ``analysed``/``skipped``/``failed`` are archive paths; ``failed``
    pairs each with its error (failed logs of earlier runs included)."""

    out: Path
    logs: int
    analysed: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)
    seconds: float = 0.0


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file beside it renamed over it."""
    from logtools.outputs import write_atomically

    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(path, lambda tmp: tmp.write_bytes(data))


def _json_bytes(doc: Any) -> bytes:
    from calib.results import json_safe

    return (json.dumps(json_safe(doc), indent=1, sort_keys=True, allow_nan=False) + "\n"
            ).encode()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("logcal")
    except PackageNotFoundError:
        return "unknown"


def _key(job: LogJob, options: AnalysisOptions) -> str:
    fp = job.settings.fingerprint if job.settings else f"error:{job.settings_error}"
    text = f"{job.content_hash}|{fp}|{options.fingerprint()}|logcal {_version()}"
    return hashlib.sha256(text.encode()).hexdigest()


def _record(job: LogJob, outcome: LogOutcome, views: dict[str, str]) -> dict[str, Any]:
    s = job.settings
    return {
        "log": job.rel, "id": job.id, "content_hash": job.content_hash,
        "robot_id": s.robot_id if s else None,
        "settings": None if s is None else {
            "robot": s.robot, "channel_map": s.channel_map, "urdf": s.urdf,
            "sources": list(s.sources)},
        "status": outcome.status, "error": outcome.error, "error_kind": outcome.error_kind,
        "detail": outcome.detail, "robot": outcome.robot, "start_ns": outcome.start_ns,
        "end_ns": outcome.end_ns, "views": views, "notes": outcome.notes,
        "result": outcome.result,
    }


@contextlib.contextmanager
def _locked(out: Path) -> Iterator[None]:
    with (out / ".lock").open("w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise LogcalInputError(
                f"{out}: another logcal batch is writing this folder; wait for it or choose "
                "another --out."
            ) from None
        yield


def _clean_partials(out: Path) -> None:
    for p in out.rglob(".*.partial*"):
        with contextlib.suppress(OSError):
            p.unlink()


def _load_manifest(out: Path) -> dict[str, Any]:
    path = out / MANIFEST
    if not path.is_file():
        return {}
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}  # unreadable: everything is redone (it is only ever replaced whole)
    logs = doc.get("logs") if isinstance(doc, dict) and doc.get("format") == FORMAT else None
    return logs if isinstance(logs, dict) else {}


def _finished(entry: Any, key: str, out: Path) -> bool:
    if not isinstance(entry, dict) or entry.get("key") != key:
        return False
    files = [entry.get("record", ""), *(entry.get("views") or {}).values()]
    return all(isinstance(f, str) and f and (out / f).is_file() for f in files)


def read_records(out: Path) -> list[dict[str, Any]]:
    """The per-log records of the logs in ``out``'s manifest, in archive order."""
    manifest = _load_manifest(out)
    records = []
    for rel in sorted(manifest):
        path = out / str(manifest[rel].get("record", ""))
        if path.is_file():
            records.append(json.loads(path.read_text(encoding="utf-8")))
    return records


def run_batch(
    archive: Path,
    out: Path,
    *,
    options: AnalysisOptions | None = None,
    engine: Engine = Engine.LOCAL,
    workers: int = 1,
    address: str | None = None,
    force: bool = False,
    progress: Callable[[BatchProgress], None] | None = None,
    report: bool = True,
) -> BatchSummary:
    """Analyse every log below ``archive`` into ``out`` (see the module docstring).

    Raises:
        LogcalInputError: ``archive`` is not a folder, ``out`` cannot be created or is in use
            by another batch, or the engine cannot start.
    """
    t0 = time.perf_counter()
    options = options or AnalysisOptions()
    out = out.resolve()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise LogcalInputError(f"--out {out}: cannot create the folder ({err}).") from err
    if archive.resolve() == out or out in archive.resolve().parents:
        raise LogcalInputError(f"--out {out}: is the archive or holds it; choose a folder "
                               "outside the archive.")
    with _locked(out):
        _clean_partials(out)
        jobs = find_logs(archive, skip=(out,))
        manifest = _load_manifest(out)
        current = {j.rel for j in jobs}
        for rel in [r for r in manifest if r not in current]:  # logs gone from the archive
            entry = manifest.pop(rel)
            for f in [entry.get("record", ""), *(entry.get("views") or {}).values()]:
                with contextlib.suppress(OSError, TypeError):
                    (out / f).unlink()
        keys = {j.rel: _key(j, options) for j in jobs}
        todo = [j for j in jobs if force or not _finished(manifest.get(j.rel), keys[j.rel], out)]
        skipped = [j.rel for j in jobs if j not in todo]
        state = BatchProgress(total=len(todo), skipped=len(skipped))
        analysed: list[str] = []

        def save_manifest() -> None:
            write_atomic(out / MANIFEST, _json_bytes({
                "format": FORMAT, "archive": str(archive.resolve()),
                "options": options.fingerprint(), "logcal": _version(), "logs": manifest}))

        save_manifest()
        if progress:
            progress(state)
        for outcome in run_jobs(todo, options, engine=engine, workers=workers, address=address):
            job = outcome.job
            views: dict[str, str] = {}
            for suffix, data in sorted(outcome.views.items()):
                rel_view = f"views/{job.id}{suffix}"
                write_atomic(out / rel_view, data)
                views[suffix] = rel_view
            record_rel = f"logs/{job.id}.json"
            write_atomic(out / record_rel, _json_bytes(_record(job, outcome, views)))
            manifest[job.rel] = {
                "id": job.id, "key": keys[job.rel], "content_hash": job.content_hash,
                "status": outcome.status, "record": record_rel, "views": views,
                "seconds": round(outcome.seconds, 3), "error": outcome.error,
            }
            save_manifest()
            analysed.append(job.rel)
            state.done += 1
            state.failed += outcome.status != "ok"
            state.last = job.rel
            if progress:
                progress(state)
        if report:
            write_fleet_outputs(out)
    failed = [(rel, str(manifest[rel].get("error"))) for rel in sorted(manifest)
              if manifest[rel].get("status") != "ok"]
    return BatchSummary(out, len(jobs), analysed, skipped, failed, time.perf_counter() - t0)


def write_fleet_outputs(out: Path) -> None:
    """Write ``fleet.parquet``, ``fleet.json`` and the HTML report from ``out``'s records."""
    from logtools.batch.fleet import fleet_summary
    from logtools.batch.report_html import write_report
    from logtools.batch.table import fleet_table, write_parquet

    records = read_records(out)
    table = fleet_table(records)
    write_parquet(table, out / "fleet.parquet")
    series = fleet_summary(table)
    write_atomic(out / "fleet.json", _json_bytes({"format": FORMAT, "series": [
        s.to_dict() for s in series]}))
    write_report(out, records, table, series)
