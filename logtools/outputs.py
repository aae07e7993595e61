"""Files logcal writes: checked before any work is done, never an input, written atomically.

An output path must have the suffix of what is written (``--rrd x.png`` would lose the
recording), must not be a directory, must sit in an existing writable directory, and must not
be one of the logs being read (``analyze in.mcap --rrd in.mcap`` would replace the drive log).
Writes go to a temporary file beside the target, renamed over it only when complete, so that an
interrupted run never leaves a half-written file.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

from logtools.errors import LogcalInputError

__all__ = ["OutputPathError", "check_output", "write_atomically"]

T = TypeVar("T")


class OutputPathError(LogcalInputError):
    """An output path logcal will not write.

    Attributes:
        option: the command-line option or role of the path (``--rrd``).
        path: the path given.
        reason: why it is refused.
    """

    def __init__(self, option: str, path: Path, reason: str) -> None:
        self.option, self.path, self.reason = option, path, reason
        super().__init__(f"{option} {path}: {reason}")


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_output(
    path: Path, *, option: str, suffixes: tuple[str, ...], inputs: Iterable[Path] = ()
) -> Path:
    """``path`` if logcal may write it (see the module docstring).

    Raises:
        OutputPathError: wrong suffix, a directory, no such or unwritable directory, or one of
            ``inputs`` (also below an input folder, e.g. inside a rosbag2 folder).
    """
    if path.suffix.lower() not in suffixes:
        raise OutputPathError(
            option, path, f"expected a file name ending in {' or '.join(suffixes)}."
        )
    if path.is_dir():
        raise OutputPathError(option, path, "is a directory; expected a file name.")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise OutputPathError(option, path, f"the directory {parent} does not exist.")
    if not os.access(parent, os.W_OK):
        raise OutputPathError(option, path, f"the directory {parent} is not writable.")
    target = path.resolve()
    for given in inputs:
        src = Path(given).resolve()
        if target == src or _same_file(target, src) or src in target.parents:
            raise OutputPathError(
                option, path, f"is the input log {given} (or inside it); logcal never "
                "overwrites an input. Choose another name."
            )
    return path


def write_atomically(path: Path, write: Callable[[Path], T]) -> T:
    """Call ``write(tmp)`` on a temporary path beside ``path`` (same suffix), then rename it
    over ``path``; the temporary file is removed when ``write`` fails."""
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.partial{path.suffix}")
    try:
        out = write(tmp)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
    return out
