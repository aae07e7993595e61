"""The input vocabulary every command that reads logs shares (``info``, ``analyze``, ``view``):
the same log arguments (files, rosbag2 folders, folders of runs, OptiOdom session folders) and
the same options saying how to read them (``--channel-map``, ``--signal``, ``--ground-truth``,
``--start``, ``--end``). The robots' own options are generated from their plugins
(:mod:`logtools.cli._robot_options`)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

if TYPE_CHECKING:  # the CLI starts without polars; commands import what they use
    from logtools.channel_map import ChannelMap
    from logtools.recordings import SameRecording

__all__ = [
    "Inputs",
    "channel_map_option",
    "check_ground_truth_clock",
    "end_option",
    "ground_truth_option",
    "logs_argument",
    "read_inputs",
    "say",
    "signal_option",
    "start_option",
    "t_max_diff_option",
    "t_offset_option",
]

LOGS_HELP = (
    "Drive logs: MCAP, CSV, ROS bags (rosbag2 folder or .bag), TUM trajectories (.tum), or "
    "folders of them (an OptiOdom session folder too)."
)


def logs_argument(help_text: str = LOGS_HELP) -> Any:
    """The ``LOG...`` argument (one or more files or folders)."""
    return typer.Argument(..., metavar="LOG", help=help_text, show_default=False)


def channel_map_option() -> Any:
    """``--channel-map FILE.toml``."""
    return typer.Option(
        None,
        "--channel-map",
        metavar="FILE.toml",
        help="TOML mapping topics/fields to logical signals (docs/LOG_FORMAT.md).",
    )


def signal_option() -> Any:
    """``--signal NAME=TOPIC:FIELD[:UNIT]`` (repeatable)."""
    return typer.Option(
        None,
        "--signal",
        metavar="NAME=TOPIC:FIELD[:UNIT]",
        help="Read a logical signal from this topic and field, as a [signals.NAME] entry of a "
        "channel map would (repeatable; wins over --channel-map). UNIT converts to SI (deg, "
        "km/h, ...) or is a transform (yaw_from_quaternion); a CSV's topic is 'csv'.",
    )


def ground_truth_option() -> Any:
    """``--ground-truth FILE.tum``."""
    return typer.Option(
        None,
        "--ground-truth",
        metavar="FILE.tum",
        help="A ground-truth trajectory on the log's clock (TUM: t x y z qx qy qz qw, s and "
        "m), whose x, y, yaw replace the log's own pose.",
    )


def t_offset_option() -> Any:
    """``--t-offset SECONDS`` (evo's ``--t_offset``)."""
    return typer.Option(
        None,
        "--t-offset",
        metavar="SECONDS|auto",
        help="Add this many seconds to the ground truth's time stamps to put them on the log's "
        "clock (as evo's --t_offset; negative: the ground truth runs ahead); auto: estimate it "
        "from the log's turn rate and the ground truth's yaw rate.",
    )


def t_max_diff_option() -> Any:
    """``--t-max-diff SECONDS`` (evo's ``--t_max_diff``)."""
    return typer.Option(
        None,
        "--t-max-diff",
        metavar="SECONDS",
        help="Pair a log's sample with the ground truth only where a ground-truth pose lies "
        "within this many seconds (as evo's --t_max_diff); default: 2.5 of the ground truth's "
        "sample periods.",
    )


def start_option() -> Any:
    """``--start SECONDS``."""
    return typer.Option(
        None,
        "--start",
        min=0.0,
        metavar="SECONDS",
        help="Use the log from this many seconds after its first sample.",
    )


def end_option() -> Any:
    """``--end SECONDS``."""
    return typer.Option(
        None,
        "--end",
        min=0.0,
        metavar="SECONDS",
        help="Use the log up to this many seconds after its first sample.",
    )


@dataclass(frozen=True)
class Inputs:
    """The logs a command reads and how.

    Attributes:
        runs: the runs (files or rosbag2 folders), folders expanded, each recording once.
        channel_map: the channel map with ``--signal`` entries, span and ground truth (None:
            defaults).
        same: files left out because they hold a recording already among ``runs``.
    """

    runs: list[Path]
    channel_map: ChannelMap | None
    same: list[SameRecording] = field(default_factory=list)

    @property
    def notes(self) -> list[str]:
        """One sentence per group of files holding one recording."""
        return [s.sentence() for s in self.same]


def read_inputs(
    logs: Iterable[Path],
    *,
    channel_map: Path | None = None,
    signals: list[str] | None = None,
    ground_truth: Path | None = None,
    start: float | None = None,
    end: float | None = None,
    dedupe: bool = True,
    t_offset: str | float | None = None,
    t_max_diff: float | None = None,
) -> Inputs:
    """Expand the log arguments, build the channel map from the options and (``dedupe``) keep
    one file per recording.

    Raises:
        LogcalInputError: a path does not exist, a folder holds no log, the channel map or a
            ``--signal`` is wrong, ``--end`` is not after ``--start``, or the ground truth is
            missing.
    """
    from logtools.channel_map import load_channel_map, with_signal_options
    from logtools.errors import LogcalInputError
    from logtools.load import LoadRequest
    from logtools.recordings import distinct_recordings
    from logtools.runs import expand_runs

    if start is not None and end is not None and end <= start:
        raise LogcalInputError(f"--end {end:g} s is not after --start {start:g} s")
    if ground_truth is not None and not ground_truth.is_file():
        raise LogcalInputError(f"--ground-truth {ground_truth}: no such file")
    offset = check_ground_truth_clock(ground_truth, t_offset, t_max_diff)
    runs = expand_runs(list(logs))
    cmap = load_channel_map(channel_map) if channel_map is not None else None
    cmap = with_signal_options(cmap, signals or [])
    cmap = LoadRequest.of(
        cmap,
        ground_truth=ground_truth,
        start_s=start,
        end_s=end,
        t_offset_s=offset if isinstance(offset, float) else None,
        t_max_diff_s=t_max_diff,
        t_offset_auto=True if offset == "auto" else None,
    )
    same: list[SameRecording] = []
    if dedupe and len(runs) > 1:
        runs, same = distinct_recordings(runs, cmap)
    return Inputs(runs, cmap, same)


def check_ground_truth_clock(
    ground_truth: Path | None, t_offset: str | float | None, t_max_diff: float | None
) -> float | str | None:
    """``--t-offset`` as seconds, "auto" or None; refused without ``--ground-truth``, not a
    finite number (or auto), or with a ``--t-max-diff`` that is not positive."""
    import math

    from logtools.errors import LogcalInputError

    offset: float | str | None = None
    if t_offset is not None:
        text = str(t_offset).strip()
        if text.lower() == "auto":
            offset = "auto"
        else:
            try:
                offset = float(text)
            except ValueError:
                offset = math.nan
            if not math.isfinite(offset):
                raise LogcalInputError(
                    f"--t-offset {text}: expected a number of seconds or auto"
                ) from None
    for flag, value in (("--t-offset", t_offset), ("--t-max-diff", t_max_diff)):
        if value is not None and ground_truth is None:
            raise LogcalInputError(
                f"{flag} {value}: it sets the clock of a ground truth; give --ground-truth FILE"
            )
    if t_max_diff is not None and not (math.isfinite(t_max_diff) and t_max_diff > 0):
        raise LogcalInputError(f"--t-max-diff {t_max_diff:g}: expected seconds above 0")
    return offset


def say(text: str, *, stderr: bool = True) -> None:
    """Print ``text`` as written (no markup, control characters escaped, no NaN shown as a
    number)."""
    from rich.console import Console

    from logtools.safe_text import no_nan, printable

    Console(stderr=stderr, highlight=False, soft_wrap=True).print(
        no_nan(printable(text)), markup=False, highlight=False
    )
