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
not this robot's (a faulty URDF). When the URDF's transmissions give mechanical reductions that
would bring a suspect factor within the limits, the note says so and names ``--effort
actuator``.

How the logged effort becomes the joint effort identified (:class:`EffortScaling`): on the
joint side (the default) as logged; on the actuator side each joint's effort times its simple
transmission's mechanical reduction and, where given, its torque constant
(:func:`actuator_scaling`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.model import ArmModel, ArmModelError
from calib.results import JsonRecord

if TYPE_CHECKING:
    from calib.manipulator.serial import Transmission

__all__ = [
    "FACTOR_LIMIT",
    "EffortScale",
    "EffortScaling",
    "JointScaling",
    "actuator_scaling",
    "effort_scale",
    "effort_unit",
    "joint_scaling",
]

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


@dataclass(frozen=True)
class JointScaling(JsonRecord):
    """How one joint's logged effort became the effort identified: times ``factor``, which is
    ``reduction`` x ``torque_constant`` on the actuator side (each 1 when absent) and 1 on the
    joint side; ``transmission`` names the URDF transmission the reduction came from."""

    factor: float = 1.0
    reduction: float | None = None
    torque_constant: float | None = None
    transmission: str | None = None


@dataclass(frozen=True)
class EffortScaling(JsonRecord):
    """Which side of the transmission the effort was logged on (``joint`` | ``actuator``), and
    per joint the scaling applied (``joints``); ``urdf``: the file the reductions came from."""

    side: str = "joint"
    joints: dict[str, JointScaling] = field(default_factory=dict)
    urdf: str | None = None

    def factors(self, names: Sequence[str]) -> Array:
        """The factor of each of ``names`` (1 for a joint not listed)."""
        return np.array([self.joints[n].factor if n in self.joints else 1.0 for n in names])


def joint_scaling(names: Sequence[str]) -> EffortScaling:
    """The effort as logged (joint side): factor 1 for every joint."""
    return EffortScaling("joint", {n: JointScaling() for n in names})


def actuator_scaling(
    names: Sequence[str],
    transmissions: Sequence[Transmission],
    urdf: str,
    torque_constants: Mapping[str, float] | None = None,
) -> EffortScaling:
    """Each joint's effort times its simple transmission's mechanical reduction, and times its
    torque constant where ``torque_constants`` gives one (a current logged in A).

    Raises:
        ArmModelError: a joint has no transmission in ``urdf``, or one that is not a simple
            transmission with a reduction (the message names the URDF and the joint).
    """
    kts = dict(torque_constants or {})
    out: dict[str, JointScaling] = {}
    for name in names:
        found = [t for t in transmissions if name in t.joints]
        if not found:
            raise ArmModelError(
                f"{urdf}: joint {name} has no <transmission>, so its actuator-side effort "
                "cannot be converted (--effort actuator): add its transmission with a "
                "mechanicalReduction to the URDF, or analyse with --effort joint (each joint's "
                "unit then set by the channel map's scale)"
            )
        t = found[0]
        if not t.simple or t.reduction is None:
            why = (
                "gives no mechanicalReduction"
                if t.simple
                else f"is a {t.kind or 'transmission without a type'} (joints "
                f"{', '.join(t.joints)}, actuators {', '.join(t.actuators) or '-'})"
            )
            raise ArmModelError(
                f"{urdf}: joint {name}: its transmission {t.name} {why}; logcal converts an "
                "actuator-side effort through a SimpleTransmission with a mechanicalReduction "
                "only (one actuator, one joint)"
            )
        kt = kts.get(name)
        out[name] = JointScaling(t.reduction * (1.0 if kt is None else kt), t.reduction, kt, t.name)
    return EffortScaling("actuator", out, urdf)


def _plausible(s: float) -> bool:
    return math.isfinite(s) and s > 0 and 1 / FACTOR_LIMIT <= s <= FACTOR_LIMIT


def effort_scale(
    model: ArmModel,
    q: Array,
    qd: Array,
    qdd: Array,
    tau: Array,
    reductions: Mapping[str, float] | None = None,
) -> EffortScale | None:
    """The check of the module docstring; None when the model has no nominal parameters.

    ``reductions``: per joint, the factor its URDF transmission would apply to an effort logged
    actuator-side (given when the effort was taken as logged): the note names ``--effort
    actuator`` for the suspect joints it would bring within the limits."""
    nominal = model.nominal
    if nominal is None:
        return None
    Y = model.regressor(q, qd, qdd)
    pred = np.einsum("njp,p->nj", Y, np.asarray(nominal, dtype=float))
    rms = np.sqrt(np.mean(pred * pred, axis=0))
    kinds_of = getattr(model, "joint_kinds", None)
    kinds = list(kinds_of()) if callable(kinds_of) else ["revolute"] * rms.size
    top = {
        k: max(float(r) for r, kk in zip(rms, kinds, strict=True) if kk == k) for k in set(kinds)
    }  # forces and torques compared within their own unit
    factors: dict[str, float | None] = {}
    suspect: list[str] = []
    for j, name in enumerate(model.joint_names):
        if top[kinds[j]] <= 0 or rms[j] < MIN_SHARE * top[kinds[j]]:
            factors[name] = None
            continue
        s = float(np.dot(tau[:, j], pred[:, j]) / np.dot(pred[:, j], pred[:, j]))
        factors[name] = s
        if not _plausible(s):
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
        red = reductions or {}
        explained = [
            n
            for n in suspect
            if factors[n] is not None
            and red.get(n, 1.0) != 1.0
            and _plausible(float(factors[n] or 0.0) * red[n])
        ]
        if explained:
            shown = ", ".join(
                f"{n} x{red[n]:g} -> x{(factors[n] or 0.0) * red[n]:.3g}" for n in explained
            )
            note += (
                f"; the URDF's transmissions would explain it: times their mechanical "
                f"reduction ({shown}) the effort fits the masses - if it is logged on the "
                "actuator side, analyse with --effort actuator"
            )
    return EffortScale(factors, tuple(suspect), note)
