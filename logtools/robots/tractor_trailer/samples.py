"""The tractor-trailer's sample drive logs of ``sample_logs/`` (its ``RobotPlugin.samples``):
two simulated runs from fixed presets and seeds, written in the three encodings, so that
``python -m logtools.sample_logs`` regenerates them byte for byte."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from calib.tractor_trailer.sim.presets import harmonic, patent_mixed
from calib.tractor_trailer.sim.tractor_trailer import (
    SimulatedRun,
    TractorTrailerSim,
    simulate_tractor_trailer,
)
from logtools.writers.tractor_trailer import Encoding, run_metadata, write_run

__all__ = ["SAMPLES", "SampleLog", "write_samples"]


@dataclass(frozen=True)
class SampleLog:
    """One sample log: file name, encoding, how to build the run, and a one-line description."""

    name: str
    encoding: Encoding
    preset: str
    make: Callable[[], TractorTrailerSim]
    seed: int
    description: str


def _clean_harmonic() -> TractorTrailerSim:
    return harmonic(duration_s=126.0, rate_hz=25.0, noise_scale=0.0)


def _mixed() -> TractorTrailerSim:
    return patent_mixed(rate_hz=20.0, noise_scale=1.0)


SAMPLES: tuple[SampleLog, ...] = (
    SampleLog(
        "tt_harmonic_clean.mcap",
        "json",
        "harmonic",
        _clean_harmonic,
        0,
        "harmonic command 0.2 sin(0.1 t) 1/m for 126 s at 1 m/s, 25 Hz (pose 12.5 Hz), no noise",
    ),
    SampleLog(
        "tt_mixed.mcap",
        "json",
        "mixed",
        _mixed,
        2,
        "harmonic, curve, linear (63 s each), constant, step (30 s each) in sequence, speed "
        "1 m/s +/- 20 %, default sensor noise, 20 Hz (pose 10 Hz), 249 s",
    ),
    SampleLog("tt_mixed_ros2.mcap", "ros2", "mixed", _mixed, 2, "the same run in ROS 2 (cdr)"),
    SampleLog("tt_mixed.csv", "csv", "mixed", _mixed, 2, "the same run as CSV"),
)
"""The tractor-trailer's sample logs (L1 = 1.25 m, L2 = 2.48 m)."""


def write_samples(
    out_dir: str | os.PathLike[str], samples: Sequence[SampleLog] = SAMPLES
) -> list[Path]:
    """Simulate and write ``samples`` into ``out_dir`` (which exists); each run is simulated
    once for all the encodings it is written in.

    Returns:
        The paths written, in order.
    """
    out = Path(out_dir)
    cache: dict[tuple[str, int], SimulatedRun] = {}
    paths = []
    for s in samples:
        key = (s.preset, s.seed)
        if key not in cache:
            cache[key] = simulate_tractor_trailer(s.make(), seed=s.seed)
        run = cache[key]
        meta = run_metadata(run, extra={"preset": s.preset})
        path = out / s.name
        write_run(path, run, encoding=s.encoding, metadata=meta)
        paths.append(path)
    return paths
