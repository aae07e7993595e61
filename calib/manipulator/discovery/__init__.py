"""Model-mismatch discovery for arms, through the shared selection engine
(:func:`calib.adequacy.select_effects`): which physics did the log's model leave out?

Catalogue (:func:`arm_catalogue`, one :class:`~calib.adequacy.EffectSpec` per joint where the
effect is a joint's):

* ``coulomb_friction(J)``, ``coulomb_friction_smooth(J)`` (its alternative with a 0.1 rad/s
  velocity scale: when the model holds one, the other is fitted *in its place*),
  ``viscous_friction(J)``, ``torque_offset(J)``: one column each;
* ``payload_mass(tool)``: a point mass at the tool point, only against a nominal rigid body (the
  link parameters the log declares): against a fitted rigid body it is regrouped into the last
  link's base parameters and cannot be seen (a payload picked up *mid-log* is a parameter change,
  :mod:`calib.manipulator.adequacy`);
* ``actuator_delay(tau)``: the torque acts ``d`` seconds after it is logged (a current-based
  torque estimate, a bus delay): the model's torque at ``t + d`` is compared with the logged
  torque at ``t``;
* ``actuator_lag(tau)``: the torque acts through a first-order lag of time constant ``T``
  (``tau_act + T tau_act' = tau_logged``); to first order the same as a delay ``d = T``, so the two
  are confounded on slow motion and listed as alternatives;
* ``joint_compliance(J)``: an elastic joint whose encoder sits on the motor side: the link is at
  ``q_J - c tau_J`` (``c = 1/k``, rad/(N·m)). The regressor is linearised in ``c`` about the fitted
  parameters (a Gauss-Newton column, ``-d(Y theta)/dq_J tau_J``, by a central difference along
  the torque), which the batch WLS fits with everything else. A compliant joint and a payload
  both change the gravity torque with the load, so they are declared confounded;
* ``joint_spring(J)``: a torque ``k q_J`` (a gravity compensator, a cable, a return spring), so
  that a spring is not absorbed into a gravity parameter or an offset;
* ``gear_play(J)``: play in the joint's gear, the encoder on the motor side: the link sits on the
  flank the torque pushes it against, ``b`` behind (``q_J - b sign(tau_J)``, smoothed), so that
  play is not taken for a payload.

What the catalogue leaves is modelled from the arm's own signals (``described``): terms of each
joint's q, qd, qdd added to its torque, refitted with the dynamic parameters. A catalogue name is
given in the report only when the final model explains the log (:mod:`calib.manipulator.explain`).

Each entry carries how it changes the model (its ``model``, an :data:`ArmEffectModel`), through
one of three mechanisms the fitter knows, never through its id:

* :class:`ColumnEffect`: columns added to the regressor (friction terms, an offset, a payload;
  a column may be fitted in place of a baseline column, or be exclusive with another);
* :class:`InputEffect`: the torque the model sees is a transform of the logged torque with one
  parameter, profiled over its bounds (a delay, a lag);
* :class:`StateEffect`: the model's inputs (q, qd, qdd) move linearly with one parameter,
  fitted by Gauss-Newton with exact regressors at each step (an elastic joint).

A new effect is one :class:`~calib.adequacy.EffectSpec` with such a hook, added by
:func:`register_effect` (or passed to :func:`arm_catalogue` as ``extra``).

The fitter (:class:`ArmFitter`) fits the baseline model (the terms the log declares, the rigid
body fitted or nominal) plus a set of effects on the first 60 % of the log (momentum windows,
WLS with Newey-West intervals; a delay or lag by a bounded 1-D search with the linear parameters
solved inside, its interval from the Gauss-Newton column at the optimum) and predicts the logged
torque on the last 40 % at the logged stamps. Residuals are divided by each joint's noise floor
(:mod:`calib.manipulator.adequacy`) so that joints in different units add. The engine accepts an
effect when its intervals exclude the null, the held-out fit improves and the BIC falls, and names
confounds (explanations within the BIC margin that imply different parameters).

Parts, one module each: ``hooks`` (the three mechanisms and the fitter view), ``columns``,
``inputs``, ``states`` (the catalogue's effects by mechanism), ``catalogue`` (the entries and the
registry), ``fitter`` (:class:`ArmFitter`), ``described`` (the residual model of what the
catalogue leaves, through :func:`calib.discovery.describe`), ``run`` (the selection, the residual
model and the result).
"""

from calib.manipulator.discovery.catalogue import (
    COMPLIANCE,
    DELAY,
    LAG,
    MAX_COMPLIANCE_JOINTS,
    PLAY,
    SPRING,
    arm_catalogue,
    register_effect,
    registered_effects,
    unregister_effect,
)
from calib.manipulator.discovery.described import describe_arm
from calib.manipulator.discovery.fitter import ArmFit, ArmFitter, joint_floors, noise_timescale
from calib.manipulator.discovery.hooks import (
    ArmEffect,
    ArmEffectModel,
    Column,
    ColumnEffect,
    FitterView,
    InputEffect,
    StateEffect,
    hook,
)
from calib.manipulator.discovery.run import (
    ArmDiscovery,
    EffectFinding,
    discover_arm,
    discovery_from_selection,
    effect_estimates,
    run_discovery,
)

__all__ = [
    "COMPLIANCE",
    "DELAY",
    "LAG",
    "MAX_COMPLIANCE_JOINTS",
    "PLAY",
    "SPRING",
    "ArmDiscovery",
    "ArmEffect",
    "ArmEffectModel",
    "ArmFit",
    "ArmFitter",
    "Column",
    "ColumnEffect",
    "EffectFinding",
    "FitterView",
    "InputEffect",
    "StateEffect",
    "arm_catalogue",
    "describe_arm",
    "discover_arm",
    "discovery_from_selection",
    "effect_estimates",
    "hook",
    "joint_floors",
    "noise_timescale",
    "register_effect",
    "registered_effects",
    "run_discovery",
    "unregister_effect",
]
