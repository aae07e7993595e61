"""Random simulated runs for discovery studies (null study, coverage checks).

A run holds nothing beyond a baseline's physics when it is simulated with the matching hitch
model ("steady" for the steady baseline, "transient" for the transient one) and no effects.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from calib.discovery.simframe import aligned_frame_from_run
from calib.results import CommandType
from calib.sim.commands import CommandSequence, CommandSpec
from calib.sim.tractor_trailer import (
    Effects,
    SimulatedRun,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)

__all__ = ["NullStudyResult", "null_study", "random_run"]

_KINDS = (
    CommandType.HARMONIC,
    CommandType.CURVE,
    CommandType.LINEAR,
    CommandType.CONSTANT,
    CommandType.STEP,
)


def random_run(
    rng: np.random.Generator,
    hitch_model: Literal["steady", "transient"],
    effects: Effects | None = None,
    duration_s: float = 90.0,
) -> SimulatedRun:
    """One run with random geometry, command mix, speed and noise seed.

    L1 in [0.8, 1.6] m, L2 in [1.8, 3.2] m; 3-5 segments of random type, amplitude 0.05-0.15
    1/m and rate 0.05-0.3 rad/s; speed 0.6-1.8 m/s with 0-30 % variation; default noise.
    """
    n_seg = int(rng.integers(3, 6))
    durations = rng.dirichlet(np.ones(n_seg)) * (duration_s - 10.0 * n_seg) + 10.0
    specs = [
        CommandSpec(
            kind=_KINDS[int(rng.integers(len(_KINDS)))],
            duration_s=float(d),
            amplitude=float(rng.uniform(0.05, 0.15) * rng.choice([-1.0, 1.0])),
            rate=float(rng.uniform(0.05, 0.3)),
            phase=float(rng.uniform(0, 2 * np.pi)),
        )
        for d in durations
    ]
    cfg = TractorTrailerSim(
        L1=float(rng.uniform(0.8, 1.6)),
        L2=float(rng.uniform(1.8, 3.2)),
        commands=CommandSequence(specs),
        speed=SpeedProfile(float(rng.uniform(0.6, 1.8)), variation=float(rng.uniform(0, 0.3))),
        effects=effects or Effects(),
        hitch_model=hitch_model,
    )
    return simulate_tractor_trailer(cfg, seed=int(rng.integers(2**31)))


@dataclass(frozen=True)
class NullStudyResult:
    """Per log: baseline used and the labels of the effects reported (empty = quiet)."""

    baselines: list[str]
    reported: list[list[str]]

    @property
    def n_logs(self) -> int:
        return len(self.reported)

    @property
    def n_quiet(self) -> int:
        return sum(1 for r in self.reported if not r)


def null_study(n_logs: int, seed: int = 0, duration_s: float = 90.0) -> NullStudyResult:
    """Run ``discover`` on ``n_logs`` runs without effects, alternating the steady and the
    transient baseline (each simulated with its own hitch model); the calibrated link lengths
    handed to discovery are the truth perturbed by up to 10 %."""
    from calib.discovery import discover  # local: the package imports this module's siblings

    rng = np.random.default_rng(seed)
    baselines, reported = [], []
    for i in range(n_logs):
        base: Literal["steady", "transient"] = "steady" if i % 2 == 0 else "transient"
        run = random_run(rng, base, duration_s=duration_s)
        L1 = run.params["L1"] * float(rng.uniform(0.9, 1.1))
        L2 = run.params["L2"] * float(rng.uniform(0.9, 1.1))
        res = discover(aligned_frame_from_run(run), L1, L2, baseline=base)
        baselines.append(base)
        reported.append([e.label for e in res.effects])
    return NullStudyResult(baselines, reported)
