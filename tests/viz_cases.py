"""Shared inputs of the viz tests: a simulated mixed-command run and a hand-made analysis."""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import polars as pl

from calib.results import AnalysisResult, CalibrationResult, Estimate
from calib.tractor_trailer.results import CommandType, MethodResult
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)
from calib.tractor_trailer.views_data import tractor_views_data

L1_TRUE, L2_TRUE = 1.25, 2.48


@dataclass(frozen=True)
class VizCase:
    frame: pl.DataFrame
    result: AnalysisResult


def _estimate(name: str, value: float, std: float) -> Estimate:
    return Estimate(name, value, std, (value - 1.96 * std, value + 1.96 * std))


def make_result(run, *, discovery: bool = True) -> AnalysisResult:
    """An AnalysisResult built by hand around ``run`` (numbers are arbitrary but distinct)."""
    methods = []
    for i, (fam, name) in enumerate(
        [("EMLS", "EMLS/EM1"), ("PMLS", "PMLS/PM1"), ("CLS", "CLS/M7"), ("EIV", "EIV")]
    ):
        for j, seg in enumerate(["all", "harmonic", "curve"]):
            methods.append(
                MethodResult(
                    name=name,
                    family=fam,
                    segment=seg,
                    L1=L1_TRUE + 0.01 * (i - 1) + 0.002 * j,
                    L2=L2_TRUE - 0.02 * (i - 1) + 0.003 * j,
                    L1_std=0.004 * (i + 1),
                    L2_std=0.006 * (i + 1) + 0.001 * j,
                    condition_number=math.nan if fam == "EIV" else 10.0 ** (i + 1),
                    n_repeats=5,
                )
            )
    l1 = _estimate("L1", 1.24, 0.01)
    l2 = _estimate("L2", 2.49, 0.02)
    estimate = CalibrationResult(
        method="EIV",
        parameters={"L1": l1, "L2": l2},
        derived={"sum_L1_L2": _estimate("L1+L2", 3.73, 0.01)},
        verdict="both lengths determined",
    )
    disc = None
    if discovery:
        t = run.truth["t_ns"].to_numpy()[::10]
        disc = SimpleNamespace(
            residuals={
                "t_ns": t,
                "psi_before": np.sin(np.arange(t.size) * 0.01) * 0.01,
                "psi_after": np.cos(np.arange(t.size) * 0.01) * 0.001,
            },
            to_dict=lambda: {"selected": []},
        )
    return AnalysisResult(
        robot="tractor_trailer",
        segments=list(run.segments),
        methods=methods,
        estimate=estimate,
        discovery=disc,
        truth={"L1": L1_TRUE, "L2": L2_TRUE},
    )


def simulate(duration_each_s: float = 20.0, rate_hz: float = 50.0):
    specs = [
        CommandSpec(CommandType.HARMONIC, duration_each_s, amplitude=0.25, rate=0.3),
        CommandSpec(CommandType.CONSTANT, duration_each_s / 2, amplitude=0.0),
        CommandSpec(CommandType.CURVE, duration_each_s, amplitude=0.2, rate=0.3),
    ]
    cfg = TractorTrailerSim(
        L1=L1_TRUE,
        L2=L2_TRUE,
        commands=CommandSequence(specs),
        speed=SpeedProfile(v_mps=1.0, ramp_s=0.0),
        rate_hz=rate_hz,
        rates_hz={"cmd": rate_hz, "odom": rate_hz, "pose": rate_hz, "hitch": rate_hz},
    )
    return simulate_tractor_trailer(cfg, seed=1)


def views_for(
    frame: pl.DataFrame, result: AnalysisResult, method_for_psi: str | None = None
) -> dict[str, np.ndarray]:
    """The views data of ``frame`` (what the analysis attaches as ``artifacts["views"]``)."""
    cols = {
        c: frame[c].cast(pl.Float64).fill_null(np.nan).to_numpy()
        for c in ("x", "y", "yaw", "psi", "kappa", "omega", "v")
        if c in frame.columns
    }
    return tractor_views_data(cols, result, method_for_psi=method_for_psi)
