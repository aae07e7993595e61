"""Write the concealed-effect sample logs (sample_logs/field_run_NN.mcap) and their truth.

Each log is a simulated tractor-trailer run written with
``logtools.writers.tractor_trailer.write_mcap_json`` and its default metadata (robot, L1, L2,
seed: nothing about the effect). File names and topics are the same for every log; which effect
each one holds is written only to tests/fixtures/concealed_truth.json. Run from the repository root:

    python bench/make_concealed_logs.py
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import polars as pl

from calib.tractor_trailer.discovery.effects import catalogue
from calib.tractor_trailer.results import CommandType as C
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    SimulatedRun,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)
from logtools.writers.tractor_trailer import write_mcap_json

ROOT = Path(__file__).resolve().parents[1]
LOG_DIR = ROOT / "sample_logs"
TRUTH = ROOT / "tests" / "fixtures" / "concealed_truth.json"

MIX_A = CommandSequence(
    [
        CommandSpec(C.HARMONIC, 30.0, 0.18, 0.25),
        CommandSpec(C.STEP, 20.0, 0.12),
        CommandSpec(C.CURVE, 20.0, -0.15, 0.3),
        CommandSpec(C.LINEAR, 20.0, 0.12, 0.2),
    ]
)
MIX_B = CommandSequence(
    [
        CommandSpec(C.STEP, 20.0, -0.1),
        CommandSpec(C.HARMONIC, 35.0, 0.15, 0.3, phase=0.5),
        CommandSpec(C.CONSTANT, 10.0, 0.08),
        CommandSpec(C.CURVE, 25.0, 0.12, 0.2),
    ]
)

# name -> (baseline the test analyses with, hitch model, effects, commands, speed, seed,
#          extra: uncatalogued psi term gain in rad per m/s^2 of lateral acceleration)
LOGS: dict[str, tuple] = {
    "field_run_01": ("steady", "transient", Effects(), MIX_B, SpeedProfile(0.5), 11, 0.0),
    "field_run_02": (
        "transient",
        "transient",
        Effects(sensor_offset={"psi": 0.03}),
        MIX_A,
        SpeedProfile(1.0, variation=0.2),
        12,
        0.0,
    ),
    "field_run_03": (
        "transient",
        "transient",
        Effects(sensor_scale={"omega": 1.08}),
        MIX_B,
        SpeedProfile(1.2, variation=0.2),
        13,
        0.0,
    ),
    "field_run_04": (
        "transient",
        "transient",
        Effects(actuator_delay_s=0.25),
        MIX_A,
        SpeedProfile(1.0),
        14,
        0.0,
    ),
    "field_run_05": (
        "transient",
        "transient",
        Effects(actuator_lag_s=0.4),
        MIX_B,
        SpeedProfile(1.0, variation=0.1),
        15,
        0.0,
    ),
    "field_run_06": (
        "transient",
        "transient",
        Effects(understeer_K=0.15),
        MIX_A,
        SpeedProfile(1.2, variation=0.35, period_s=30.0),
        16,
        0.0,
    ),
    "field_run_07": (
        "transient",
        "transient",
        Effects(clock_offset_s={"hitch": 0.3}),
        MIX_B,
        SpeedProfile(1.0),
        17,
        0.0,
    ),
    "field_run_08": (
        "transient",
        "transient",
        Effects(clock_offset_s={"hitch": 0.2}, sensor_offset={"psi": -0.025}),
        MIX_A,
        SpeedProfile(1.0, variation=0.2),
        18,
        0.0,
    ),
    "field_run_09": ("transient", "transient", Effects(), MIX_B, SpeedProfile(1.0), 19, 0.0),
    "field_run_10": (
        "transient",
        "transient",
        Effects(),
        MIX_A,
        SpeedProfile(1.2, variation=0.3, period_s=30.0),
        20,
        0.05,
    ),
    "field_run_11": (
        "transient",
        "transient",
        Effects(clock_offset_s={"odom": 0.15}),
        MIX_B,
        SpeedProfile(1.0, variation=0.2),
        21,
        0.0,
    ),
    "field_run_12": (
        "transient",
        "transient",
        Effects(sensor_offset={"omega": 0.01}),
        MIX_A,
        SpeedProfile(1.0),
        22,
        0.0,
    ),
}

L1_TRUE, L2_TRUE = 1.25, 2.48

_SIM_TO_EFFECT = {
    e.spec.sim_switch: (e.id, e.params[0].name) for e in catalogue("steady") if e.spec.sim_switch
}
"""Simulator switch (a key of the run's parameters, before any ".target") -> (effect id, its
parameter), from calib's catalogue entries."""


def expected_effects(params: dict[str, float], baseline: str, hitch: str) -> list[dict]:
    """The catalogue effects discovery should name, with the true parameter values."""
    out = []
    if baseline == "steady" and hitch == "transient":
        out.append(
            {
                "id": "hitch_transient",
                "target": None,
                "parameter": "relaxation_length",
                "value": L2_TRUE,
            }
        )
    for key, value in params.items():
        head, _, target = key.partition(".")
        if head in _SIM_TO_EFFECT:
            eid, par = _SIM_TO_EFFECT[head]
            out.append({"id": eid, "target": target or None, "parameter": par, "value": value})
    return out


def _with_lateral_slip(run: SimulatedRun, gain: float) -> SimulatedRun:
    """Add gain * v^2 kappa (true lateral acceleration at the sample times) to the joint angle:
    a trailer that slips sideways under lateral acceleration (not in the catalogue)."""
    truth = run.truth
    a_lat = np.interp(
        run.frames["hitch"]["t_ns"].to_numpy().astype(float),
        truth["t_ns"].to_numpy().astype(float),
        (truth["v"] ** 2 * truth["kappa"]).to_numpy(),
    )
    hitch = run.frames["hitch"].with_columns(pl.col("psi") + gain * a_lat)
    return dataclasses.replace(run, frames={**run.frames, "hitch": hitch})


def main() -> None:
    truth: dict[str, dict] = {}
    for name, (baseline, hitch, effects, commands, speed, seed, slip) in LOGS.items():
        cfg = TractorTrailerSim(
            L1=L1_TRUE,
            L2=L2_TRUE,
            commands=commands,
            speed=speed,
            effects=effects,
            hitch_model=hitch,
        )
        run = simulate_tractor_trailer(cfg, seed=seed)
        params = {k: v for k, v in run.params.items() if k not in ("L1", "L2")}
        if slip:
            run = _with_lateral_slip(run, slip)
            params["uncatalogued.lateral_slip_rad_per_mps2"] = slip
        path = LOG_DIR / f"{name}.mcap"
        write_mcap_json(path, run)
        truth[f"{name}.mcap"] = {
            "baseline": baseline,
            "hitch_model": hitch,
            "L1": L1_TRUE,
            "L2": L2_TRUE,
            "effects": params,
            "expected": expected_effects(params, baseline, hitch),
            "segments": [s.to_dict() for s in run.segments],
        }
        print(f"{path.relative_to(ROOT)}: {path.stat().st_size / 1e6:.2f} MB, {params}")
    TRUTH.write_text(json.dumps(truth, indent=2) + "\n")
    print(f"truth -> {TRUTH.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
