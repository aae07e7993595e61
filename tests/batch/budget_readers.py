"""Readers that misbehave, for the batch budget tests: registered in the test process and, by
``engines._WORKER_SETUP = "budget_readers:install"``, in every spawned worker. Each reads a CSV
export (the file's content) after misbehaving, so that a log whose misbehaviour is not stopped
is analysed and the test sees it.

* ``.hang``: sleeps in ``time.sleep`` (interrupted by the time budget's alarm);
* ``.stuck``: masks ``SIGALRM`` and sleeps, as C code that never returns to the interpreter
  (only the hard stop ends it);
* ``.hog``: asks numpy for ``HOG_GIB`` GiB (not touched: without a memory budget it succeeds
  at no cost, with one it fails).
"""

from __future__ import annotations

import signal
import time
from pathlib import Path

from logtools.readers import LogData
from logtools.readers import formats as registry
from logtools.readers.format_reader import FormatReader, ReadRequest

HOG_GIB = 12
SUFFIXES = (".hang", ".stuck", ".hog")


def _csv_read(path: str, req: ReadRequest) -> LogData:
    csv = next(r for r in registry.formats() if r.name == "csv")
    return csv.read(path, req)


def _hang(path: str, req: ReadRequest) -> LogData:
    time.sleep(600)
    return _csv_read(path, req)


def _stuck(path: str, req: ReadRequest) -> LogData:
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})
    time.sleep(600)
    return _csv_read(path, req)


def _hog(path: str, req: ReadRequest) -> LogData:
    import numpy as np

    block = np.empty(HOG_GIB * 2**30, dtype=np.uint8)
    del block
    return _csv_read(path, req)


def _reader(suffix: str, read: object) -> FormatReader:
    return FormatReader(
        f"test{suffix}",
        f"test reader {suffix}",
        (suffix,),
        lambda path, head: Path(path).suffix == suffix,
        read,
    )  # type: ignore[arg-type]


def install() -> None:
    """Register the three readers (first: asked before CSV)."""
    for suffix, read in ((".hang", _hang), (".stuck", _stuck), (".hog", _hog)):
        registry.register_format(_reader(suffix, read), first=True)
