"""logcal's own formats as registry entries (:mod:`logtools.readers.formats`): how each is
recognised and read. The readers themselves live in their modules (``mcap_reader``,
``rosbag_reader``, ``csv_reader``, ``optiodom``, ``tum``)."""

from __future__ import annotations

from pathlib import Path

from logtools.errors import NotAnMcapError
from logtools.readers.base import TIME_COLUMN, ColumnFilter, LogData
from logtools.readers.format_reader import FormatReader, ReadRequest

__all__ = ["BUILTIN", "kept"]

_BATCHED_MIN_BYTES = 2**20
"""Smaller MCAP files are read whole (no batch could hold less than all of their chunks)."""


def kept(log: LogData, keep: ColumnFilter | None) -> LogData:
    """``log`` with only the columns ``keep`` keeps (and ``t_ns``)."""
    if keep is None:
        return log
    for topic, frame in log.topics.items():
        cols = [c for c in frame.columns if c == TIME_COLUMN or keep(topic, c)]
        if len(cols) != frame.width:
            log.topics[topic] = frame.select(cols)
    return log


def _whole(name: str) -> bytes:
    try:
        # unbuffered: the whole-file read is one allocation of the file's size (through a
        # buffered reader it grows a second copy, twice the file for a moment)
        with open(name, "rb", buffering=0) as fh:
            return fh.readall()
    except OSError as err:
        raise NotAnMcapError(name, f"cannot read it: {err.strerror or err}") from err
    except MemoryError as err:
        raise NotAnMcapError(name, "the file does not fit in memory") from err


# ----------------------------------------------------------------------------- MCAP


def _sniff_mcap(path: Path, head: bytes) -> bool:
    from logtools.readers.mcap_scan import MAGIC

    return head[: len(MAGIC)] == MAGIC or (
        path.suffix.lower() == ".mcap" and len(head) < len(MAGIC) and MAGIC.startswith(head)
    )


def _read_mcap(name: str, req: ReadRequest) -> LogData:
    from logtools.readers.decoders import DEFAULT_DECODERS
    from logtools.readers.mcap_reader import read_mcap, read_mcap_batched
    from logtools.readers.mcap_scan import MAGIC

    decoders = req.decoders if req.decoders is not None else DEFAULT_DECODERS
    if req.size >= _BATCHED_MIN_BYTES:  # a large intact MCAP: a batch at a time
        batched = read_mcap_batched(name, req.size, req.topics, decoders, req.keep, req.span_ns)
        if batched is not None:
            return batched
    buf = _whole(name)
    if not buf:
        raise NotAnMcapError(name, "the file is empty")
    if buf[: len(MAGIC)] != MAGIC:
        raise NotAnMcapError(name, f"only {len(buf)} bytes of an MCAP header: truncated")
    return read_mcap(name, buf, req.topics, decoders, req.keep)


# ----------------------------------------------------------------------------- ROS bags


def _sniff_bag_folder(path: Path, head: bytes) -> bool:
    from logtools.readers.rosbag_reader import is_rosbag

    return is_rosbag(path)


def _sniff_bag_file(path: Path, head: bytes) -> bool:
    from logtools.readers.mcap_scan import MAGIC
    from logtools.readers.rosbag_reader import is_rosbag

    return head[: len(MAGIC)] != MAGIC and is_rosbag(path, head[:24])


def _read_bag(name: str, req: ReadRequest) -> LogData:
    from logtools.readers.rosbag_reader import read_rosbag

    return kept(read_rosbag(name, req.topics), req.keep)


# ----------------------------------------------------------------------------- CSV and kin


def _looks_like_csv(head: bytes) -> bool:
    from logtools.readers.csv_reader import TIME_COLUMNS

    first = head.split(b"\n", 1)[0]
    try:
        text = first.decode("utf-8").strip()
    except UnicodeDecodeError:
        return False
    names = {c for c, _ in TIME_COLUMNS}
    return "," in text and any(c.strip().strip('"') in names for c in text.split(","))


def _sniff_csv(path: Path, head: bytes) -> bool:
    return path.suffix.lower() == ".csv" or _looks_like_csv(head)


def _read_csv(name: str, req: ReadRequest) -> LogData:
    from logtools.readers.csv_reader import read_csv_file

    size = req.size or Path(name).stat().st_size
    if not size:
        raise NotAnMcapError(name, "the file is empty")
    return kept(read_csv_file(name, size), req.keep)


def _sniff_optiodom(path: Path, head: bytes) -> bool:
    from logtools.readers.optiodom import is_optiodom_run

    return is_optiodom_run(path, head)


def _read_optiodom(name: str, req: ReadRequest) -> LogData:
    from logtools.readers.optiodom import read_optiodom

    return kept(read_optiodom(name), req.keep)


def _optiodom_runs(folder: Path) -> list[Path]:
    from logtools.readers.optiodom import session_runs

    return session_runs(folder)


def _optiodom_metadata(path: Path) -> bool:
    from logtools.readers.optiodom import is_optiodom_metadata

    return is_optiodom_metadata(path)


def _sniff_tum(path: Path, head: bytes) -> bool:
    from logtools.readers.tum import is_tum

    return is_tum(path, head)


def _read_tum(name: str, req: ReadRequest) -> LogData:
    from logtools.readers.tum import read_tum

    return kept(read_tum(name), req.keep)


BUILTIN: tuple[FormatReader, ...] = (
    FormatReader(
        "rosbag2",
        "ROS 2 bag folder (metadata.yaml with .db3 or .mcap storage)",
        (),
        _sniff_bag_folder,
        _read_bag,
        folder=True,
    ),
    FormatReader(
        "rosbag", "ROS bag file (ROS 1 .bag, rosbag2 .db3)", (".bag",), _sniff_bag_file, _read_bag
    ),
    FormatReader(
        "mcap",
        "MCAP (JSON, ROS 2, ROS 1 or protobuf messages)",
        (".mcap",),
        _sniff_mcap,
        _read_mcap,
    ),
    FormatReader(
        "optiodom",
        "OptiOdom session run (headerless CSV beside *_metadata.csv)",
        (".csv",),
        _sniff_optiodom,
        _read_optiodom,
        runs=_optiodom_runs,
        skip=_optiodom_metadata,
    ),
    FormatReader("tum", "TUM trajectory (t x y z qx qy qz qw)", (".tum",), _sniff_tum, _read_tum),
    FormatReader(
        "csv",
        "CSV export (a time column t, __time, %time or timestamp)",
        (".csv",),
        _sniff_csv,
        _read_csv,
    ),
)
