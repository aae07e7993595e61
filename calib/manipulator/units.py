"""Is the logged effort a torque in N·m (N for a prismatic joint)? A check against the model's
own masses.

A drive logged the usual way may record a motor current (A), a torque before the gear, or a
torque in another unit; identified as N·m it gives masses a hundred times off (the TIAGo arm's
raw currents gave a total mass of 0.095 kg for a published 19.02 kg). Where the model carries
nominal parameters (a URDF's inertias), the effort those need on the logged motion is computed
and compared with the logged one joint by joint: the least-squares factor s with
logged ~ s * nominal. A factor outside [1/``FACTOR_LIMIT``, ``FACTOR_LIMIT``], or negative (a
flipped sign), is said plainly with both readings: the effort is in another unit (give a torque
constant times gear ratio as the channel map's per-joint ``scale``), or the model's masses are
not this robot's (a faulty URDF).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.model import ArmModel
from calib.results import JsonRecord

__all__ = ["FACTOR_LIMIT", "EffortScale", "effort_scale", "effort_unit"]

FACTOR_LIMIT = 3.0
MIN_SHARE = 0.2
"""A joint whose nominal effort on this motion is below this share of the largest joint's is not
judged (a joint that hardly moves and carries little tells nothing about the unit)."""

Array = NDArray[np.float64]


def effort_unit(kind: str) -> str:
    """N for a ``prismatic`` joint's force, N·m for a ``revolute`` joint's torque."""
    return "N" if kind == "prismatic" else "N·m"


@dataclass(frozen=True)
class EffortScale(JsonRecord):
    """Per joint, the factor between the logged effort and what the model's nominal parameters
    need (``factors``; None where not judged), the joints whose factor is implausible
    (``suspect``) and ``note`` for people (empty when every judged joint is plausible)."""

    factors: dict[str, float | None]
    suspect: tuple[str, ...]
    note: str


def effort_scale(
    model: ArmModel, q: Array, qd: Array, qdd: Array, tau: Array
) -> EffortScale | None:
    """The check of the module docstring; None when the model has no nominal parameters."""
    nominal = model.nominal
    if nominal is None:
        return None
    Y = model.regressor(q, qd, qdd)
    pred = np.einsum("njp,p->nj", Y, np.asarray(nominal, dtype=float))
    rms = np.sqrt(np.mean(pred * pred, axis=0))
    kinds_of = getattr(model, "joint_kinds", None)
    kinds = list(kinds_of()) if callable(kinds_of) else ["revolute"] * rms.size
    top = {k: max(float(r) for r, kk in zip(rms, kinds, strict=True) if kk == k)
           for k in set(kinds)}  # forces and torques compared within their own unit
    factors: dict[str, float | None] = {}
    suspect: list[str] = []
    for j, name in enumerate(model.joint_names):
        if top[kinds[j]] <= 0 or rms[j] < MIN_SHARE * top[kinds[j]]:
            factors[name] = None
            continue
        s = float(np.dot(tau[:, j], pred[:, j]) / np.dot(pred[:, j], pred[:, j]))
        factors[name] = s
        if not math.isfinite(s) or s <= 0 or not (1 / FACTOR_LIMIT <= s <= FACTOR_LIMIT):
            suspect.append(name)
    note = ""
    if suspect:
        shown = ", ".join(f"{n} x{factors[n]:.3g}" for n in suspect if factors[n] is not None)
        note = (
            f"the logged effort and the model's nominal masses disagree on this motion "
            f"(logged = factor x nominal: {shown}): either the effort is not in N·m (N for a "
            "prismatic joint) - a motor current or a torque before the gear: give each joint's "
            "torque constant x gear ratio as the channel map's scale ([signals.tauN] scale = "
            "...), and the identified masses are in the logged unit until then - or the URDF's "
            "masses are not this robot's"
        )
    return EffortScale(factors, tuple(suspect), note)
