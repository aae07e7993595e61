"""Sampling of the true run into per-topic messages: rates, jitter, dropouts, stalls, noise.

Order of operations per topic: nominal instants phase + k / rate inside [0, duration];
true instants = nominal + sampling jitter (stamped correctly); dropped: independent
dropouts, burst dropouts and recorder stalls (all by the true instant); value = sensor_scale *
true + sensor_offset + Gaussian noise, then quantised; stamp = true instant + stamp noise +
clock offset of the group, as int64 ns from ``scenario.start_ns``. Yaw fields are wrapped to
[-pi, pi). Random streams are per topic group (a group's draws do not depend on which other
groups are present).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .inputs import FloatArray
from .physics import Trajectory, integrate
from .scenario import TOPICS, Scenario, TopicSpec

__all__ = ["Generated", "TopicData", "generate"]

_GROUP_INDEX = {g: i for i, g in enumerate(sorted({g for r in TOPICS.values() for g in r}))}


@dataclass(frozen=True)
class TopicData:
    """One topic's messages: ``stamps_ns`` (int64, as stamped), ``t_true`` (s, true sample
    instants since start), ``fields`` (name -> float64 array, the recorded values)."""

    topic: str
    group: str
    stamps_ns: NDArray[np.int64]
    t_true: FloatArray
    fields: dict[str, FloatArray]


@dataclass(frozen=True)
class Generated:
    """A generated log: ``topics`` keyed by topic name, the ``truth`` dict, the continuous
    ``trajectory`` (true state at any time), the ``scenario`` and ``seed``.

    ``truth``: robot, L1, L2, wheelbase, drive_gain, duration_s, start_ns, seed, ``effects``
    (active effects as {key: {param: value}}, keys as in calib's catalogue plus
    ``trailer_slip``), ``stalls`` [(start_s, end_s)], ``topics`` {topic: {rate_hz, phase_s,
    count}}, max_abs_psi, distance_m (path length of C1), n_rhs (ODE evaluations).
    """

    scenario: Scenario
    seed: int
    topics: dict[str, TopicData]
    truth: dict[str, Any]
    trajectory: Trajectory


def _clipped_normal(rng: np.random.Generator, std: float, bound: float, n: int) -> FloatArray:
    if std <= 0:
        return np.zeros(n)
    return np.clip(rng.normal(0.0, std, n), -bound, bound)


def _sample(
    spec: TopicSpec, T: float, rng: np.random.Generator, stalls: list[tuple[float, float]]
) -> tuple[float, FloatArray, FloatArray]:
    period = 1.0 / spec.rate_hz
    phase = float(rng.uniform(0.0, period))
    nominal = phase + period * np.arange(math.floor((T - phase) / period) + 1)
    t = nominal + _clipped_normal(rng, spec.sample_jitter_s, 0.2 * period, nominal.size)
    stamp_err = _clipped_normal(rng, spec.stamp_noise_s, 0.2 * period, nominal.size)
    keep = (t >= 0.0) & (t <= T)
    if spec.drop_prob > 0:
        keep &= rng.random(t.size) >= spec.drop_prob
    n_bursts = int(rng.poisson(spec.bursts_per_min * T / 60.0)) if spec.bursts_per_min else 0
    windows = [(s, s + float(rng.uniform(*spec.burst_s))) for s in rng.uniform(0.0, T, n_bursts)]
    for a, b in windows + stalls:
        keep &= (t < a) | (t >= b)
    return phase, t[keep], stamp_err[keep]


def generate(scenario: Scenario, seed: int = 0) -> Generated:
    """Integrate ``scenario`` and sample every topic, with randomness from ``seed``."""
    traj = integrate(scenario)
    T = scenario.duration_s
    eff = scenario.effects
    rng = np.random.default_rng([seed, 0])
    stalls: list[tuple[float, float]] = []
    for _ in range(scenario.n_stalls):
        ln = float(rng.uniform(min(0.2, scenario.max_stall_s), scenario.max_stall_s))
        s = float(rng.uniform(0.05 * T, max(0.05 * T, 0.95 * T - ln)))
        stalls.append((s, s + ln))
    defs = TOPICS[scenario.robot]
    topics: dict[str, TopicData] = {}
    topic_truth: dict[str, dict[str, float]] = {}
    for group, spec in scenario.topics.items():
        if group not in defs:
            raise ValueError(f"topic group {group!r} is not one of {scenario.robot}: {list(defs)}")
        tdef = defs[group]
        grng = np.random.default_rng([seed, 1 + _GROUP_INDEX[group]])
        phase, t, stamp_err = _sample(spec, T, grng, stalls)
        sig = traj.signals(t)
        fields: dict[str, FloatArray] = {}
        for f, name in zip(tdef.fields, tdef.signals, strict=True):
            val = sig[name] * eff.sensor_scale.get(name, 1.0) + eff.sensor_offset.get(name, 0.0)
            sd = spec.noise.get(f, 0.0)
            if sd > 0:
                val = val + grng.normal(0.0, sd, t.size)
            q = spec.quantum.get(f, 0.0)
            if q > 0:
                val = np.round(val / q) * q
            if f == "yaw":
                val = (val + np.pi) % (2 * np.pi) - np.pi
            fields[f] = np.asarray(val, dtype=float)
        stamp_s = t + stamp_err + eff.clock_offset_s.get(group, 0.0)
        stamps = scenario.start_ns + np.round(stamp_s * 1e9).astype(np.int64)
        topics[tdef.topic] = TopicData(tdef.topic, group, stamps, t, fields)
        topic_truth[tdef.topic] = {"rate_hz": spec.rate_hz, "phase_s": phase, "count": t.size}
    dense = np.linspace(0.0, T, max(2001, int(T * 50)))
    sig = traj.signals(dense)
    distance = float(np.sum(np.hypot(np.diff(sig["x"]), np.diff(sig["y"]))))
    truth: dict[str, Any] = {
        "robot": scenario.robot,
        "L1": scenario.L1,
        "L2": scenario.L2,
        "wheelbase": scenario.wheelbase,
        "drive_gain": scenario.drive_gain,
        "duration_s": T,
        "start_ns": scenario.start_ns,
        "seed": seed,
        "effects": eff.truth(),
        "stalls": stalls,
        "topics": topic_truth,
        "max_abs_psi": float(np.max(np.abs(sig["psi"]))),
        "distance_m": distance,
        "n_rhs": traj.n_rhs,
    }
    return Generated(scenario, seed, topics, truth, traj)
