"""The arm's catalogue: one :class:`~calib.discovery.EffectSpec` per effect (per joint where
the effect is a joint's), each with its hook (:mod:`calib.manipulator.discovery.hooks`), and the
registry through which effects are added from outside."""

from __future__ import annotations

import math
from collections.abc import Sequence

from calib.discovery import EffectKind, EffectParam, EffectRegistry, EffectSpec
from calib.manipulator.design import ALTERNATIVES, Term, term_name, term_unit
from calib.manipulator.discovery.columns import PayloadColumn, SpringColumn, TermColumn
from calib.manipulator.discovery.hooks import (
    ArmEffectModel,
    ColumnEffect,
    InputEffect,
    StateEffect,
)
from calib.manipulator.discovery.inputs import DelayInput, LagInput
from calib.manipulator.discovery.states import ComplianceState, PlayState

__all__ = [
    "COMPLIANCE",
    "DELAY",
    "DELAY_BOUNDS",
    "LAG",
    "LAG_BOUNDS",
    "MAX_COMPLIANCE_JOINTS",
    "PLAY",
    "REGISTRY",
    "SPRING",
    "TOOL_TARGET",
    "TORQUE_TARGET",
    "arm_catalogue",
    "register_effect",
    "registered_effects",
    "unregister_effect",
]

DELAY = "actuator_delay"
LAG = "actuator_lag"
COMPLIANCE = "joint_compliance"
SPRING = "joint_spring"
PLAY = "gear_play"
TORQUE_TARGET = "tau"
TOOL_TARGET = "tool"
DELAY_BOUNDS = (-0.05, 0.1)
"""Search range of the actuation delay (s): a negative delay is a torque logged late."""
LAG_BOUNDS = (0.0, 0.1)
"""Search range of the first-order lag's time constant (s)."""
MAX_COMPLIANCE_JOINTS = 3
"""Joint compliance is tried on arms with at most this many joints: each joint's column needs
the full regressor at two perturbed states along the whole log (memory and time grow with n^2)."""

_TERM_PHYSICS = {
    Term.COULOMB: "Coulomb friction, tanh(qd / 0.01 rad/s)",
    Term.COULOMB_SMOOTH: "friction building up over 0.1 rad/s (pre-sliding, lubricated gear)",
    Term.VISCOUS: "viscous friction",
    Term.OFFSET: "a constant torque offset (sensor or current-estimate bias)",
}


def _hook_problem(spec: EffectSpec[ArmEffectModel]) -> str | None:
    if isinstance(spec.model, ColumnEffect | InputEffect | StateEffect):
        return None
    return "no model hook (a ColumnEffect, InputEffect or StateEffect)"


REGISTRY: EffectRegistry[EffectSpec[ArmEffectModel]] = EffectRegistry(
    "arm", key=lambda e: e.key, check=_hook_problem
)
"""Effects added to every arm catalogue from outside (``calib.discovery``'s one registry
behaviour; the built-in ones are per joint, so a registered key is checked against the
registered ones)."""


def register_effect(spec: EffectSpec[ArmEffectModel]) -> EffectSpec[ArmEffectModel]:
    """Add ``spec`` (with its hook) to every arm catalogue built from now on; returns it."""
    return REGISTRY.register(spec)


def unregister_effect(spec: EffectSpec[ArmEffectModel] | str) -> None:
    """Take a registered effect (or its key) out again (no error when it is not registered)."""
    REGISTRY.unregister(spec)


def registered_effects() -> tuple[EffectSpec[ArmEffectModel], ...]:
    """The effects added by :func:`register_effect`, in order."""
    return REGISTRY.entries()


def arm_catalogue(
    joints: Sequence[str],
    baseline: Sequence[Term] = (),
    *,
    nominal: bool = False,
    extra: Sequence[EffectSpec[ArmEffectModel]] = (),
) -> tuple[EffectSpec[ArmEffectModel], ...]:
    """The arm's catalogue for these joints, leaving out the terms the baseline already has
    (their alternatives stay: they are fitted in their place); then the registered effects
    (:func:`register_effect`) and ``extra``."""
    out: list[EffectSpec[ArmEffectModel]] = []
    base = set(baseline)
    for term in (Term.COULOMB, Term.COULOMB_SMOOTH, Term.VISCOUS, Term.OFFSET):
        if term in base:
            continue
        conf = (f"{ALTERNATIVES[term]}",) if term in ALTERNATIVES else ()
        for j in joints:
            name = term_name(term, j)
            out.append(
                EffectSpec(
                    str(term),
                    j,
                    EffectKind.SENSOR if term is Term.OFFSET else EffectKind.DYNAMICS,
                    (EffectParam(name, term_unit(term), 0.0, -math.inf, math.inf, 0.0),),
                    _TERM_PHYSICS[term],
                    tuple(f"{c}({j})" for c in conf),
                    sim_switch="friction",
                    truth_key=name,
                    model=TermColumn(term, j),
                )
            )
    for j in joints:
        out.append(
            EffectSpec(
                SPRING,
                j,
                EffectKind.DYNAMICS,
                (EffectParam(f"k[{j}]", "N*m/rad", 0.0, -math.inf, math.inf, 0.0),),
                "a spring on the joint: a torque linear in its angle (a gravity compensator, a "
                "cable or hose, a return spring)",
                (f"{Term.OFFSET}({j})", f"{Term.PAYLOAD}({TOOL_TARGET})"),
                truth_key=f"k[{j}]",
                model=SpringColumn(j),
            )
        )
    if nominal:
        out.append(
            EffectSpec(
                str(Term.PAYLOAD),
                TOOL_TARGET,
                EffectKind.DYNAMICS,
                (EffectParam("payload", "kg", 0.0, -math.inf, math.inf, 0.0),),
                "a point mass held at the tool point",
                tuple(f"{e}({j})" for e in (COMPLIANCE, PLAY, SPRING) for j in joints),
                sim_switch="payload",
                truth_key="payload",
                model=PayloadColumn(),
            )
        )
    out.append(
        EffectSpec(
            DELAY,
            TORQUE_TARGET,
            EffectKind.ACTUATOR,
            (EffectParam("d", "s", 0.0, *DELAY_BOUNDS, 0.0),),
            "the torque acts d seconds after it is logged",
            (f"{LAG}({TORQUE_TARGET})",),
            sim_switch="delay_s",
            truth_key="delay_s",
            model=DelayInput(),
        )
    )
    out.append(
        EffectSpec(
            LAG,
            TORQUE_TARGET,
            EffectKind.ACTUATOR,
            (EffectParam("T", "s", 0.0, *LAG_BOUNDS, 0.0),),
            "the torque acts through a first-order lag of time constant T",
            (f"{DELAY}({TORQUE_TARGET})",),
            sim_switch="lag_s",
            truth_key="lag_s",
            model=LagInput(),
        )
    )
    if len(joints) <= MAX_COMPLIANCE_JOINTS:
        for j in joints:
            out.append(
                EffectSpec(
                    COMPLIANCE,
                    j,
                    EffectKind.DYNAMICS,
                    (EffectParam(f"c[{j}]", "rad/(N*m)", 0.0, -math.inf, math.inf, 0.0),),
                    "an elastic joint: the encoder reads the motor side, the link is at q - c tau",
                    (f"{Term.PAYLOAD}({TOOL_TARGET})",),
                    sim_switch="compliance",
                    truth_key=f"c[{j}]",
                    model=ComplianceState(j),
                )
            )
        for j in joints:
            out.append(
                EffectSpec(
                    PLAY,
                    j,
                    EffectKind.DYNAMICS,
                    (EffectParam(f"b[{j}]", "rad", 0.0, -math.inf, math.inf, 0.0),),
                    "play in the joint's gear: the encoder reads the motor side, the link sits "
                    "on the flank the torque pushes it against, b behind (q - b sign(tau))",
                    (f"{COMPLIANCE}({j})", f"{Term.PAYLOAD}({TOOL_TARGET})"),
                    truth_key=f"b[{j}]",
                    model=PlayState(j),
                )
            )
    out += [*REGISTRY.entries(), *extra]
    return tuple(out)
