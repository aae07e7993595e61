"""Which side of the transmission an arm's logged effort is on (``--effort joint|actuator``),
and the scaling that turns it into the joint effort the identification needs.

The effort a ROS arm logs in ``/joint_states`` may be the joint's torque or the actuator's
(a motor torque before the gear, or a current). With ``--effort actuator`` each joint's effort
is multiplied by the mechanical reduction of its URDF ``<transmission>``
(:func:`calib.manipulator.serial.read_transmissions`) and, where the channel map's ``[robot]``
table gives ``torque_constant_<joint>`` (N·m/A; N/A for a prismatic joint), by that too. The
channel map's per-signal ``scale``/``offset`` are applied first, when the signal is read:
joint effort = (field x scale + offset) x reduction x torque constant.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from calib.errors import CalibError
from calib.manipulator.units import EffortScaling, actuator_scaling, joint_scaling
from logtools.errors import LogcalInputError
from logtools.loaded import LoadedLog
from logtools.robots.manipulator.options import EffortSide, ManipulatorOptions

if TYPE_CHECKING:
    from calib.manipulator.model import ArmModel
    from logtools.analysis_config import AnalysisConfig

__all__ = ["TORQUE_CONSTANT", "EffortChoice", "effort_choice", "torque_constants"]

TORQUE_CONSTANT = "torque_constant_"
"""Prefix of a channel map ``[robot]`` key giving one joint's torque constant."""


@dataclass(frozen=True)
class EffortChoice:
    """The scaling applied (``scaling``), the factor each joint's simple transmission would
    apply on the actuator side (``would``: for the effort check's note when the effort is taken
    as logged) and notes for the result's warnings."""

    scaling: EffortScaling
    would: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def torque_constants(
    params: Mapping[str, float], joints: tuple[str, ...], where: str
) -> dict[str, float]:
    """The channel map's ``[robot] torque_constant_<joint>`` entries, by joint.

    Raises:
        LogcalInputError: one names no logged joint, or is zero or not finite.
    """
    out: dict[str, float] = {}
    for key, value in params.items():
        if not key.startswith(TORQUE_CONSTANT):
            continue
        joint = key[len(TORQUE_CONSTANT) :]
        if joint not in joints:
            raise LogcalInputError(
                f"{where}: [robot] {key}: {joint!r} is not a joint of this log; expected "
                f"{TORQUE_CONSTANT}<joint> with a joint among {', '.join(joints)}"
            )
        if not math.isfinite(value) or value == 0:
            raise LogcalInputError(
                f"{where}: [robot] {key} = {value!r}: expected a nonzero "
                "torque constant (N·m/A; N/A for a prismatic joint)"
            )
        out[joint] = float(value)
    return out


def _params(loaded: LoadedLog) -> dict[str, float]:
    cfg: Any = getattr(loaded, "robot_config", None)
    return dict(getattr(cfg, "params", None) or {})


def effort_choice(loaded: LoadedLog, config: AnalysisConfig, model: ArmModel) -> EffortChoice:
    """The scaling of ``--effort`` (default ``joint``) for ``model``'s joints.

    Raises:
        LogcalInputError: ``actuator`` without a URDF, a joint without a simple transmission
            (naming the URDF and the joint), or a bad torque constant.
    """
    side = config.options(ManipulatorOptions).effort or EffortSide.JOINT
    names = tuple(model.joint_names)
    kts = torque_constants(_params(loaded), names, f"{loaded.path}: channel map")
    source = str(getattr(model, "source", "") or "")
    if side is EffortSide.ACTUATOR:
        if not source:
            raise LogcalInputError(
                f"{loaded.path}: --effort actuator needs the arm's URDF (its transmissions' "
                "mechanical reductions): give --urdf PATH_OR_NAME"
            )
        try:
            scaling = actuator_scaling(names, getattr(model, "transmissions", ()), source, kts)
        except CalibError as err:
            raise LogcalInputError(f"{loaded.path}: {err}") from err
        return EffortChoice(scaling)
    notes = []
    if kts:
        notes.append(
            f"channel map [robot]: the torque constants ({', '.join(kts)}) are "
            "applied with --effort actuator only; the effort was taken as logged "
            "(joint side)"
        )
    would: dict[str, float] = {}
    try:
        found = getattr(model, "transmissions", ()) if source else ()
    except CalibError:
        found = ()  # the check's hint only; --effort actuator or `info` says what is wrong
    for name in names:
        t = next((t for t in found if name in t.joints), None)
        if t is not None and t.simple and t.reduction is not None:
            would[name] = t.reduction * kts.get(name, 1.0)
    return EffortChoice(joint_scaling(names), would, notes)
