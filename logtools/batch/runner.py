"""``logcal batch``: analyse every log of an archive, resumably, then write the fleet outputs.

The output folder holds::

    manifest.json          every log (by id): name, content hash, settings key, status, time
    journal.jsonl          logs finished since the manifest was last written (append-only)
    logs/<id>.json         per log: its settings, span, status, error or AnalysisResult JSON
    views/<id>.rrd, .png   per log: rerun recording and static image (when its robot has them)
    fleet.parquet          the fleet table (logtools.batch.table)
    fleet.json             pooled estimates and drift per robot and parameter
    index.html, pages/     the HTML report (logtools.batch.report_html)

Resuming: a log is analysed again only when its manifest entry is missing, its key (content
hash, logcal.toml settings and the files they name, analysis options with the --start/--end
bounds, logcal version) differs,
or one of its output files is gone; ``force`` redoes all. Every file is written to a temporary
name and renamed over its target (``os.replace``). After each log, one line is appended to the
journal (its files are written before): the time per log does not grow with the number of logs
(the manifest used to be rewritten whole after each, quadratic in the archive's size). At the
start and the end of a run the journal is folded into ``manifest.json`` (written atomically,
then the journal removed). A batch killed at any moment leaves whole files only, and its
finished logs are not redone (a torn last journal line is ignored: that log is redone).
Leftover temporary files are removed at the next run. A lock file keeps two batches from
writing one folder at once. Every file and journal line is flushed to the disk (``fsync``)
before the next step counts on it, so a power cut leaves the previous state or the new one.

Nothing is deleted by omission: the record of a log that is gone from the archive (a moved
file, an unmounted share, a wrong but existing path) is kept, marked ``gone`` and reported;
``prune=True`` (``--prune``) drops such records, and only when the archive was read whole and
holds at least one log (an empty archive or a folder that cannot be listed never prunes).
A full disk (or any error writing ``DIR``) stops the batch with one message naming the file:
what was written stays whole and a rerun resumes.

Nothing read back from ``DIR`` is trusted as a path: entries are keyed by log id (checked
against :data:`~logtools.batch.archive.ID_PATTERN`), and every file name is derived from the id
(``logs/<id>.json``, ``views/<id>.rrd``), so a crafted manifest cannot make a batch read or
delete a file outside ``DIR``.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import os
import shutil
import stat
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from logtools.batch.archive import ID_PATTERN, UNLISTED, LogJob, find_logs
from logtools.batch.budgets import Budgets
from logtools.batch.engines import Engine, run_jobs
from logtools.batch.files import open_regular
from logtools.batch.worker import AnalysisOptions, LogOutcome, analyse_job, log_span
from logtools.errors import LogcalInputError
from logtools.outputs import fsync_folder, special_filesystem

__all__ = [
    "JOURNAL",
    "MANIFEST",
    "BatchProgress",
    "BatchSummary",
    "load_manifest",
    "prune_refusal",
    "read_records",
    "run_batch",
    "write_atomic",
]

MANIFEST = "manifest.json"
JOURNAL = "journal.jsonl"
FORMAT = "logcal-batch/2"
_FORMAT_1 = "logcal-batch/1"  # keyed by the log's name: read, converted to ids
SUBDIRS = ("logs", "views", "pages", "plots")
VIEW_SUFFIXES = (".rrd", ".png")


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
    pairs each with its error (failed logs of earlier runs included). ``gone``: records kept
    whose log is no longer in the archive; ``pruned``: records dropped by ``prune``;
    ``prune_refused``: why ``prune`` dropped nothing (empty or partly unreadable archive)."""

    out: Path
    logs: int
    analysed: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)
    seconds: float = 0.0
    gone: list[str] = field(default_factory=list)
    pruned: list[str] = field(default_factory=list)
    prune_refused: str | None = None


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file beside it renamed over it."""
    from logtools.outputs import write_atomically

    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        write_atomically(path, lambda tmp: tmp.write_bytes(data))
    except OSError as err:
        if err.filename is None:  # a write (not an open) failed: name the target
            err.filename = str(path)
        raise


def _json_bytes(doc: Any) -> bytes:
    from calib.results import json_safe

    return (json.dumps(json_safe(doc), indent=1, sort_keys=True, allow_nan=False) + "\n").encode()


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("logcal")
    except PackageNotFoundError:
        return "unknown"


def _key(job: LogJob, options: AnalysisOptions, version: str) -> str:
    if job.entry_error is not None:
        fp = f"entry:{job.entry_error}"
    else:
        fp = job.settings.fingerprint if job.settings else f"error:{job.settings_error}"
    text = f"{job.content_hash}|{fp}|{options.fingerprint()}|logcal {version}"
    return hashlib.sha256(text.encode("utf-8", "surrogateescape")).hexdigest()


def _text(value: str) -> str:
    """``value`` encodable as UTF-8: bytes of an undecodable file name (surrogates, in an
    error message that quotes the path) shown as ``\\xNN``, as in the log's name."""
    try:
        value.encode("utf-8")
        return value
    except UnicodeEncodeError:
        try:
            return value.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
        except UnicodeEncodeError:
            return value.encode("utf-8", "backslashreplace").decode("utf-8")


def _clean(doc: Any) -> Any:
    """``doc`` with every string (keys too) made UTF-8 encodable by :func:`_text`."""
    if isinstance(doc, str):
        return _text(doc)
    if isinstance(doc, dict):
        return {_clean(k): _clean(v) for k, v in doc.items()}
    if isinstance(doc, list | tuple):
        return [_clean(v) for v in doc]
    return doc


def _span(job: LogJob, options: AnalysisOptions) -> dict[str, float | None]:
    """The span the log was analysed over (seconds from its first sample; None: unbounded)."""
    start, end = log_span(job.settings, options)
    return {"start_s": start, "end_s": end}


def _record(
    job: LogJob, outcome: LogOutcome, views: dict[str, str], options: AnalysisOptions
) -> dict[str, Any]:
    return _clean({**_record_raw(job, outcome, views), "span": _span(job, options)})


def _record_raw(job: LogJob, outcome: LogOutcome, views: dict[str, str]) -> dict[str, Any]:
    s = job.settings
    return {
        "log": job.rel,
        "id": job.id,
        "content_hash": job.content_hash,
        "robot_id": s.robot_id if s else None,
        "settings": None
        if s is None
        else {
            "robot": s.robot,
            "channel_map": s.channel_map,
            "options": dict(s.options),
            "sources": list(s.sources),
        },
        "status": outcome.status,
        "error": outcome.error,
        "error_kind": outcome.error_kind,
        "detail": outcome.detail,
        "robot": outcome.robot,
        "start_ns": outcome.start_ns,
        "end_ns": outcome.end_ns,
        "views": views,
        "notes": outcome.notes,
        "result": outcome.result,
    }


def _open_nofollow(path: Path, flags: int) -> int:
    return os.open(path, flags | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0), 0o644)


@contextlib.contextmanager
def _locked(out: Path) -> Iterator[None]:
    try:  # never through a link planted at .lock, never truncating what is there
        fd = _open_nofollow(out / ".lock", os.O_WRONLY | os.O_CREAT)
    except OSError as err:
        raise LogcalInputError(
            f"--out {out}: cannot create its lock file .lock ({err.strerror or err})."
        ) from err
    with os.fdopen(fd, "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise LogcalInputError(
                f"{out}: another logcal batch is writing this folder; wait for it or choose "
                "another --out."
            ) from None
        yield


def _prepare_subdirs(out: Path) -> None:
    """Create ``logs``, ``views``, ``pages``, ``plots``; refuse any that is a link or a file
    (writing through a planted link would put files outside ``out``)."""
    for name in SUBDIRS:
        sub = out / name
        try:
            sub.mkdir(exist_ok=True)
            mode = os.lstat(sub).st_mode
        except OSError as err:
            raise LogcalInputError(
                f"--out {out}: cannot create {name}/ ({err.strerror or err})."
            ) from err
        if not stat.S_ISDIR(mode):
            raise LogcalInputError(
                f"--out {out}: {name} is not a folder (a link or a file); "
                "logcal writes only into real folders of --out."
            )


def _clean_partials(out: Path) -> None:
    """Remove the temporaries of an interrupted run (in ``out`` and its own subfolders)."""
    for folder in (out, *(out / s for s in SUBDIRS)):
        try:
            with os.scandir(folder) as it:
                entries = [e for e in it if e.name.startswith(".") and ".partial" in e.name]
        except OSError:
            continue
        for e in entries:
            with contextlib.suppress(OSError):
                if e.is_dir(follow_symlinks=False):
                    shutil.rmtree(e.path)
                else:
                    os.unlink(e.path)


def _read_json_file(path: Path) -> Any:
    """JSON of a regular file of ``out`` (a link or FIFO planted there is not read); None when
    it is absent or unreadable."""
    try:
        fd = open_regular(path)
    except OSError:
        return None
    try:
        with os.fdopen(fd, "rb") as fh:
            return json.loads(fh.read())
    except (OSError, ValueError):
        return None


def _valid_entry(ident: Any, entry: Any) -> dict[str, Any] | None:
    """The manifest entry with its file names derived from the id, or None when the id is not
    one of ours or the entry is malformed (then it is ignored: the log is redone)."""
    if not isinstance(ident, str) or not ID_PATTERN.fullmatch(ident):
        return None
    if not isinstance(entry, dict):
        return None
    views = entry.get("views") or {}
    if not isinstance(views, dict) or any(s not in VIEW_SUFFIXES for s in views):
        return None
    clean = dict(entry)
    clean["id"] = ident
    clean["log"] = str(entry.get("log", ident))
    clean["record"] = f"logs/{ident}.json"
    clean["views"] = {s: f"views/{ident}{s}" for s in sorted(views)}
    return clean


def load_manifest(out: Path) -> dict[str, dict[str, Any]]:
    """The entries of ``out``'s manifest and journal, by log id (validated: see the module
    docstring); empty when there is none."""
    logs: dict[str, dict[str, Any]] = {}
    doc = _read_json_file(out / MANIFEST)
    items: list[tuple[Any, Any]] = []
    if isinstance(doc, dict) and isinstance(doc.get("logs"), dict):
        if doc.get("format") == FORMAT:
            items = list(doc["logs"].items())
        elif doc.get("format") == _FORMAT_1:
            items = [
                (e.get("id"), {**e, "log": rel})
                for rel, e in doc["logs"].items()
                if isinstance(e, dict)
            ]
    for ident, entry in items:
        valid = _valid_entry(ident, entry)
        if valid is not None:
            logs[valid["id"]] = valid
    try:
        fd = open_regular(out / JOURNAL)
    except OSError:
        return logs
    with os.fdopen(fd, "rb") as fh:
        for line in fh:
            try:
                item = json.loads(line)
            except ValueError:
                continue  # a line torn by a kill: that log is redone
            if not isinstance(item, dict):
                continue
            if item.get("drop") is True and isinstance(item.get("id"), str):
                logs.pop(item["id"], None)
                continue
            valid = _valid_entry(item.get("id"), item.get("entry"))
            if valid is not None:
                logs[valid["id"]] = valid
    return logs


def _files(ident: str, views: Any) -> list[str]:
    return [
        f"logs/{ident}.json",
        *(f"views/{ident}{s}" for s in VIEW_SUFFIXES if isinstance(views, dict) and s in views),
    ]


def _finished(entry: dict[str, Any] | None, key: str, out: Path) -> bool:
    if entry is None or entry.get("key") != key:
        return False
    return all(os.path.isfile(out / f) for f in _files(entry["id"], entry.get("views")))


def read_records(out: Path) -> list[dict[str, Any]]:
    """The per-log records of the logs in ``out``'s manifest, in archive order."""
    manifest = load_manifest(out)
    records = []
    for ident in sorted(manifest, key=lambda i: (manifest[i]["log"], i)):
        record = _read_json_file(out / "logs" / f"{ident}.json")
        if isinstance(record, dict):
            record["id"] = ident  # file names in the report come from the checked id only
            record["gone"] = manifest[ident].get("gone") is True
            record["views"] = manifest[ident]["views"]
            record["log"] = str(record.get("log", manifest[ident]["log"]))
            records.append(record)
    return records


class _Journal:
    """``journal.jsonl``: one JSON line appended per finished log (never rewritten)."""

    def __init__(self, out: Path) -> None:
        self.fd = _open_nofollow(out / JOURNAL, os.O_RDWR | os.O_CREAT | os.O_APPEND)
        size = os.fstat(self.fd).st_size
        if size and os.pread(self.fd, 1, size - 1) != b"\n":  # a line torn by a kill
            self._write(b"\n")  # ends it: the next line is read on its own

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            written = os.write(self.fd, view)
            if written <= 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), JOURNAL)
            view = view[written:]
        os.fsync(self.fd)

    def append(self, item: dict[str, Any]) -> None:
        from calib.results import json_safe

        line = json.dumps(json_safe(item), sort_keys=True, allow_nan=False) + "\n"
        self._write(line.encode())

    def close(self) -> None:
        os.close(self.fd)


def _compact(
    out: Path, manifest: dict[str, Any], archive: Path, options: AnalysisOptions, version: str
) -> None:
    """Fold the journal into ``manifest.json`` (written atomically), then remove the journal
    (a kill in between replays it on top of the same entries: no loss)."""
    write_atomic(
        out / MANIFEST,
        _json_bytes(
            {
                "format": FORMAT,
                "archive": os.fsencode(str(archive)).decode("utf-8", "replace"),
                "options": options.fingerprint(),
                "logcal": version,
                "logs": manifest,
            }
        ),
    )
    with contextlib.suppress(FileNotFoundError):
        os.unlink(out / JOURNAL)
    fsync_folder(out)


def _is_rosbag2_folder(path: Path) -> bool:
    return os.path.isdir(path) and os.path.lexists(path / "metadata.yaml")


def check_out(archive: Path, out: Path) -> Path:
    """``out`` resolved, if a batch may write there: not on a kernel file system, not the
    archive or a folder holding it, and never inside an input (a rosbag2 folder of the
    archive). Checked before anything is created.

    Raises:
        LogcalInputError: why not.
    """
    archive_res, out_res = archive.resolve(), out.resolve()
    root = special_filesystem(out_res)
    if root is not None:
        raise LogcalInputError(
            f"--out {out}: is on the kernel file system {root}; choose a folder on disk."
        )
    if archive_res == out_res or out_res in archive_res.parents:
        raise LogcalInputError(
            f"--out {out_res}: is the archive or holds it; choose a folder outside the archive."
        )
    if archive_res in out_res.parents:
        for folder in (out_res, *out_res.parents):
            if folder == archive_res:
                break
            if _is_rosbag2_folder(folder):
                raise LogcalInputError(
                    f"--out {out_res}: is inside the rosbag2 folder {folder}, one of the "
                    "archive's logs; logcal never writes into an input. Choose a folder "
                    "outside it."
                )
    return out_res


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
    budgets: Budgets | None = None,
    prune: bool = False,
) -> BatchSummary:
    """Analyse every log below ``archive`` into ``out`` (see the module docstring), each under
    ``budgets`` of memory and time (default: :func:`~logtools.batch.engines.run_jobs`'s).
    Records of logs gone from the archive are kept (``BatchSummary.gone``) unless ``prune``
    (and even then only when the archive is read whole and not empty).

    Raises:
        LogcalInputError: ``archive`` is not a folder, ``out`` cannot be created, is on a
            kernel file system, inside an input, or in use by another batch, or the engine
            cannot start; or a file of ``out`` cannot be written (a full disk: the message
            names the file, what was written stays whole).
    """
    t0 = time.perf_counter()
    options = options or AnalysisOptions()
    if not archive.resolve().is_dir():
        from logtools.readers.formats import log_suffixes

        raise LogcalInputError(
            f"{archive.resolve()}: not a folder; expected an archive of "
            f"logs ({', '.join(log_suffixes())} files, rosbag2 folders)."
        )
    out = check_out(archive, out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise LogcalInputError(f"--out {out}: cannot create the folder ({err}).") from err
    version = _version()
    try:
        with _locked(out):
            return _run_locked(
                archive,
                out,
                options,
                version,
                engine=engine,
                workers=workers,
                address=address,
                force=force,
                prune=prune,
                progress=progress,
                report=report,
                budgets=budgets,
                t0=t0,
            )
    except OSError as err:
        if err.errno not in _WRITE_ERRNOS:
            raise
        raise LogcalInputError(_write_error(out, err)) from err


_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})
"""Errors writing ``--out`` that are the machine's state, not a bug: one message, exit 2."""


def _write_error(out: Path, err: OSError) -> str:
    where = f" ({err.filename})" if err.filename else ""
    return (
        f"--out {out}: cannot write{where}: {err.strerror or err}; the files written so far "
        "are whole and a rerun resumes where this one stopped."
    )


def prune_refusal(jobs: list[LogJob]) -> str | None:
    """Why records of logs missing from ``jobs`` must not be dropped, or None when they may:
    the archive holds no log at all (an unmounted share, a wrong path), or a folder of it
    could not be listed (its logs were not seen)."""
    unlisted = [j.rel or "." for j in jobs if j.entry_error and UNLISTED in j.entry_error]
    if unlisted:
        return (
            f"{len(unlisted)} folder(s) of the archive cannot be listed ({unlisted[0]}...); "
            "records are pruned only when the whole archive is read"
        )
    if not jobs:
        return "the archive holds no log (an unmounted share or a wrong path?); nothing pruned"
    return None


def _run_locked(
    archive: Path,
    out: Path,
    options: AnalysisOptions,
    version: str,
    *,
    engine: Engine,
    workers: int,
    address: str | None,
    force: bool,
    prune: bool,
    progress: Callable[[BatchProgress], None] | None,
    report: bool,
    budgets: Budgets | None,
    t0: float,
) -> BatchSummary:
    _prepare_subdirs(out)
    _clean_partials(out)
    jobs = find_logs(archive, skip=(out,))
    manifest = load_manifest(out)
    current = {j.id for j in jobs}
    missing = [i for i in manifest if i not in current]  # logs gone from the archive
    refusal = prune_refusal(jobs) if prune and missing else None
    pruned: list[str] = []
    for ident in missing:
        if prune and refusal is None:
            entry = manifest.pop(ident)
            pruned.append(str(entry["log"]))
            for f in _files(ident, entry.get("views")):
                with contextlib.suppress(OSError):
                    os.unlink(out / f)
        else:
            manifest[ident]["gone"] = True  # kept, reported: never deleted by omission
    for ident in current & set(manifest):
        manifest[ident].pop("gone", None)
    keys = {j.id: _key(j, options, version) for j in jobs}
    todo = [j for j in jobs if force or not _finished(manifest.get(j.id), keys[j.id], out)]
    todo_ids = {j.id for j in todo}
    skipped = [j.rel for j in jobs if j.id not in todo_ids]
    state = BatchProgress(total=len(todo), skipped=len(skipped))
    analysed: list[str] = []
    _compact(out, manifest, archive, options, version)
    if progress:
        progress(state)
    # entries refused before analysis (links, FIFOs, bad logcal.toml) fail here, at once
    early = [j for j in todo if j.entry_error is not None or j.settings is None]
    rest = [j for j in todo if j.entry_error is None and j.settings is not None]
    journal = _Journal(out)
    try:
        outcomes = run_jobs(
            rest, options, engine=engine, workers=workers, address=address, budgets=budgets
        )
        for outcome in _chain((analyse_job(j, options) for j in early), outcomes):
            job = outcome.job
            views: dict[str, str] = {}
            for suffix, data in sorted(outcome.views.items()):
                if suffix not in VIEW_SUFFIXES:
                    continue
                rel_view = f"views/{job.id}{suffix}"
                write_atomic(out / rel_view, data)
                views[suffix] = rel_view
            record_rel = f"logs/{job.id}.json"
            write_atomic(out / record_rel, _json_bytes(_record(job, outcome, views, options)))
            manifest[job.id] = {
                "id": job.id,
                "log": job.rel,
                "key": keys[job.id],
                "content_hash": job.content_hash,
                "status": outcome.status,
                "record": record_rel,
                "views": views,
                "span": _span(job, options),
                "seconds": round(outcome.seconds, 3),
                "error": None if outcome.error is None else _text(outcome.error),
            }
            journal.append({"id": job.id, "entry": manifest[job.id]})
            analysed.append(job.rel)
            state.done += 1
            state.failed += outcome.status != "ok"
            state.last = job.rel
            if progress:
                progress(state)
    finally:
        journal.close()
    _compact(out, manifest, archive, options, version)
    if report:
        write_fleet_outputs(out)
    by_name = sorted(manifest, key=lambda i: (manifest[i]["log"], i))
    failed = [
        (str(manifest[i]["log"]), str(manifest[i].get("error")))
        for i in by_name
        if manifest[i].get("status") != "ok" and not manifest[i].get("gone")
    ]
    gone = [str(manifest[i]["log"]) for i in by_name if manifest[i].get("gone")]
    return BatchSummary(
        out,
        len(jobs),
        analysed,
        skipped,
        failed,
        time.perf_counter() - t0,
        gone=gone,
        pruned=sorted(pruned),
        prune_refused=refusal,
    )


def _chain(*parts: Any) -> Iterator[LogOutcome]:
    for part in parts:
        yield from part


def write_fleet_outputs(out: Path) -> None:
    """Write ``fleet.parquet``, ``fleet.json`` and the HTML report from ``out``'s records."""
    from logtools.batch.fleet import fleet_summary
    from logtools.batch.report_html import write_report
    from logtools.batch.table import fleet_table, write_parquet

    records = read_records(out)
    table = fleet_table(records)
    write_parquet(table, out / "fleet.parquet")
    series = fleet_summary(table)
    write_atomic(
        out / "fleet.json", _json_bytes({"format": FORMAT, "series": [s.to_dict() for s in series]})
    )
    write_report(out, records, table, series)
