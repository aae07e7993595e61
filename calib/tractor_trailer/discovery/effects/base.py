"""The interface every physical effect of the discovery catalogue implements.

An effect is a model extension: it owns a few parameters (with units, bounds and the value at
which it does nothing) and changes the model at one stage: the inputs (commanded curvature and
speed as the vehicle feels them), the hitch dynamics (relaxation length) or the outputs (what
the sensors record). It is also its own catalogue entry: ``spec`` is the shared
:class:`calib.adequacy.EffectSpec` (kind from its stage, parameters, the effects it is known to
be confounded with, the simulator switch that produces it, its truth key) whose ``model`` hook
is the effect itself, so reports, the pipeline and the studies read those from the effect
instead of lists of ids.

An effect also declares the explanations the recordings may not tell it from
(``Effect.equivalents``: which effects or robot parameters, and how one side's parameters
convert into the other's) and what it says about the joint-angle sensor in the terms a fit of
the link lengths along the measured path takes in (``Effect.joint_angle_correction``): the
confirmation of the effects and the confounds of the link lengths read these declarations and
know no effect by its key.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from calib.discovery import EffectKind, EffectParam, EffectSpec
from calib.results import json_safe
from calib.tractor_trailer.discovery.jumps import jump_intervals

if TYPE_CHECKING:
    from calib.tractor_trailer.discovery.data import DiscoveryData

__all__ = [
    "PARAM",
    "Convert",
    "Effect",
    "Equivalent",
    "FloatArray",
    "ParamSpec",
    "SensorCorrections",
    "Values",
    "hold_interp",
    "jump_intervals",
    "remembered",
    "shift",
]

FloatArray = NDArray[np.float64]
T = TypeVar("T")
STAGE_KIND = {0: EffectKind.ACTUATOR, 1: EffectKind.DYNAMICS, 2: EffectKind.SENSOR}
"""The kind of an effect at each stage: the inputs as the vehicle feels them (the actuator's
response to its command), the hitch dynamics, the outputs (what a sensor records)."""
REMEMBERED = 6  # results an effect remembers (``remembered``)


Values = Mapping[str, Mapping[str, float]]
"""Parameter values per effect key."""
Convert = Callable[[Values, "DiscoveryData"], dict[str, dict[str, float]]]
"""From one side's fitted values (and the log's conditions), starting values of the other's."""
PARAM = "param:"
"""Prefix of a robot parameter (``param:L1``) among the keys of an equivalent explanation."""


@dataclass(frozen=True)
class SensorCorrections:
    """What an explanation says about the joint-angle sensor, in the terms a fit of the link
    lengths along the measured path can take in: ``psi_offset`` (fit a constant offset of the
    recorded joint angle), ``psi_shift_s`` (the joint-angle topic is stamped this many seconds
    late: compare the model at t - shift), ``psi_scale`` (recorded = scale x true: divide the
    recorded angle by it; 1.0 for none); ``labels``: the effects they come from. Effects on the
    actuator (dead time, lag, understeer) and on the yaw rate do not enter such a fit."""

    psi_offset: bool = False
    psi_shift_s: float = 0.0
    psi_scale: float = 1.0
    labels: tuple[str, ...] = ()

    @property
    def empty(self) -> bool:
        return not self.psi_offset and self.psi_shift_s == 0.0 and self.psi_scale == 1.0

    def same_as(self, other: SensorCorrections, *, shift_tol_s: float = 0.0) -> bool:
        """The same corrections (time shifts within ``shift_tol_s``; scales to 1e-9)."""
        return (
            self.psi_offset == other.psi_offset
            and abs(self.psi_shift_s - other.psi_shift_s) <= shift_tol_s
            and abs(self.psi_scale - other.psi_scale) <= 1e-9
        )

    def combined(self, other: SensorCorrections) -> SensorCorrections:
        """Both corrections at once: an offset if either has one, the time shifts added, the
        gains multiplied, the labels of both."""
        return SensorCorrections(
            self.psi_offset or other.psi_offset,
            self.psi_shift_s + other.psi_shift_s,
            self.psi_scale * other.psi_scale,
            (*self.labels, *other.labels),
        )

    def as_tuple(self) -> tuple[bool, float, list[str]]:
        """(fit a joint-angle offset, joint-angle clock shift in s, labels): the shape of the
        ``calib.tractor_trailer.judgement.folded_effects``."""
        return self.psi_offset, self.psi_shift_s, list(self.labels)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "psi_offset": self.psi_offset,
                "psi_shift_s": self.psi_shift_s,
                "psi_scale": self.psi_scale,
                "labels": list(self.labels),
            }
        )


@dataclass(frozen=True)
class Equivalent:
    """An explanation that changes the recordings (nearly) as the declaring effect does
    (``Effect.equivalents``).

    ``rule``: its name in reports (``AlternativeExplanation.rule``, ``LengthConfound.rule``);
    ``note``: why the two look alike and what tells them apart. ``mine``: keys of the
    declaring side (the declaring effect's, with any that go with it); ``theirs``: keys of the
    other side, effects or robot parameters (``PARAM`` + name).

    Between effects: ``to_theirs``/``to_mine`` give one side's starting values from the
    other's fitted ones (unit conversions: a dead time into clock offsets, understeer into a
    yaw-rate gain); ``exact``: the two change the recordings alike wherever the log's
    conditions hold throughout (constant speed), rather than only approximately (slow
    commands): exact equivalences are tried first. ``agree``, ``agree_note``: a parameter of
    ``theirs`` whose values agreeing with each other are the declaring side's signature (a
    dead time looks like the same offset on every topic's clock), and what that agreement
    says.

    With robot parameters (the log fixes only a combination of the effect and the parameters,
    so there is no conversion): the effect is fitted free beside them; ``what``: the effect's
    parameter in words; ``assumes``: what the parameters fitted without it assume of it;
    ``span_within``: the effect's interval is spanned (refit at its ends) only within its null
    +/- this, wider the parameters are not determined by the log.
    """

    rule: str
    note: str
    mine: tuple[str, ...]
    theirs: tuple[str, ...]
    to_theirs: Convert | None = None
    to_mine: Convert | None = None
    exact: bool = True
    agree: str = ""
    agree_note: str = ""
    what: str = ""
    assumes: str = ""
    span_within: float = 0.0

    @property
    def of_parameters(self) -> bool:
        """The other side is robot parameters (``PARAM``), not effects."""
        return bool(self.theirs) and all(k.startswith(PARAM) for k in self.theirs)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of the robot parameters on the other side."""
        return tuple(k.removeprefix(PARAM) for k in self.theirs if k.startswith(PARAM))


@dataclass(frozen=True)
class ParamSpec:
    """One effect parameter.

    Args:
        name: parameter name (unique within the effect).
        unit: unit string for reports.
        init: starting value of the fit.
        lower, upper: bounds of the fit.
        null: value at which the effect does nothing (tested against for significance).
        starts: extra starting values tried (for parameters with several local minima).
        time_shift: the parameter is a time (a shift, a lag's time constant); its interval
            then includes the time resolution (a jump is only known to lie within one sample
            period; ``DiscoveryData.time_resolution_s``).
    """

    name: str
    unit: str
    init: float
    lower: float
    upper: float
    null: float
    starts: tuple[float, ...] = ()
    time_shift: bool = False


class Effect:
    """Base class: one physical effect as a model extension (defaults change nothing).

    Subclasses set ``id``, ``stage`` (0 inputs, 1 hitch dynamics, 2 outputs), ``order`` within
    the stage, ``params`` and ``channels`` (the modelled outputs it changes), and override the
    hooks they need; for their catalogue entry (``spec``) also ``kind`` (default: the stage's,
    ``STAGE_KIND``), ``confounded_with`` (keys of effects, or "param:" robot parameters, the
    log may not tell it from; ``equivalents`` says how, for those the confirmation and the
    confounds check) and ``sim_switch`` (the option of
    :class:`calib.tractor_trailer.sim.tractor_trailer.Effects` that produces it; per target
    when the effect has one).
    """

    id: str = ""
    stage: int = 0
    order: int = 0
    kind: EffectKind | None = None
    confounded_with: tuple[str, ...] = ()
    sim_switch: str = ""
    in_baselines: tuple[str, ...] = ()
    """Baselines ("steady", "transient") that already contain this effect's physics: it is no
    candidate against them."""

    def __init__(self, target: str | None = None) -> None:
        self.target = target

    @property
    def key(self) -> str:
        """Unique name of this catalogue entry, e.g. ``sensor_offset(psi)``; ``id`` alone for
        an effect without a target (``actuator_delay``). The same as ``spec.key``: reports,
        JSON, ``confounded_with``, equivalences and a simulated log's truth all use it."""
        return self.id if self.target is None else f"{self.id}({self.target})"

    @property
    def params(self) -> tuple[ParamSpec, ...]:
        raise NotImplementedError

    @property
    def spec(self) -> EffectSpec[Effect]:
        """This effect as a catalogue entry, its hook the effect itself. ``spec.key`` and the
        truth key are ``key`` (an effect without a target has the empty target)."""
        doc = (type(self).__doc__ or self.id).strip().splitlines()[0]
        return EffectSpec(
            self.id,
            self.target or "",
            self.kind or STAGE_KIND[self.stage],
            tuple(
                EffectParam(p.name, p.unit, p.null, p.lower, p.upper, p.init) for p in self.params
            ),
            doc,
            confounded_with=self.confounded_with,
            sim_switch=self.sim_switch,
            truth_key=self.key,
            model=self,
        )

    @property
    def channels(self) -> tuple[str, ...]:
        """Modelled outputs ("omega", "psi") this effect changes."""
        raise NotImplementedError

    def explanation(self, values: Mapping[str, float]) -> str:
        """Plain-language account of the effect with its fitted ``values``."""
        raise NotImplementedError

    def equivalents(self, channels: tuple[str, ...]) -> tuple[Equivalent, ...]:
        """Explanations a log of the recorded ``channels`` may not tell this effect from, with
        how their parameters convert (``Equivalent``). Declare each pair once, on one side;
        the keys of both sides belong in the effects' ``confounded_with``. Default: none."""
        return ()

    def joint_angle_correction(self, p: Mapping[str, float]) -> SensorCorrections | None:
        """What this effect with parameters ``p`` says about the joint-angle sensor, as a
        fit of the link lengths along the measured path takes it in (labelled with ``key``),
        or None if nothing (or if ``p`` is no valid such correction). Default: None."""
        return None

    def modify_inputs(
        self, t_s: FloatArray, kappa: FloatArray, v: FloatArray, p: Mapping[str, float]
    ) -> tuple[FloatArray, FloatArray]:
        """Curvature (1/m) and speed (m/s) as the vehicle feels them, on the full-rate grid."""
        return kappa, v

    @property
    def changes_inputs(self) -> bool:
        """Whether ``modify_inputs`` can change the inputs (the model's inputs are then
        recomputed when this effect's parameters change; ``model.predict``)."""
        return type(self).modify_inputs is not Effect.modify_inputs

    def input_delay(self, p: Mapping[str, float]) -> float:
        """Dead time (s) between the recorded command and the curvature it produces."""
        return 0.0

    def relaxation_length(self, p: Mapping[str, float]) -> float | None:
        """Relaxation length (m) of the joint angle, or None to leave the baseline's."""
        return None

    def modify_output(
        self, name: str, t_s: FloatArray, y: FloatArray, p: Mapping[str, float]
    ) -> FloatArray:
        """What the sensor of output ``name`` records, given the modelled truth ``y``."""
        return y

    def true_from_recorded(self, name: str, y: float, p: Mapping[str, float]) -> float:
        """The inverse of ``modify_output`` at one value: the true output ``name`` behind a
        recorded ``y`` (the joint-angle model restarts from a recorded angle; a sensor effect
        must be taken out of it first). Default: the effect does not change what is recorded
        (a time shift is left in: the angle barely moves within one)."""
        return y

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.key})"


def remembered(
    owner: Effect, key: Hashable, arrays: tuple[FloatArray, ...], make: Callable[[], T]
) -> T:
    """``make()``, remembered on ``owner`` for the last ``REMEMBERED`` (``key``, input arrays)
    pairs; arrays are matched by identity, and only read-only ones (the model's remembered
    intermediate results, ``model.predict``): an array that may still change is no key.

    Why: within a fit the model is evaluated again and again with most parameters unchanged;
    an expensive step of an effect whose own inputs and parameters did not move (a lag when
    only the speed or a link length moved) need not run again. Results that are arrays are
    made read-only, so that the next effect can remember its own step on them in turn.
    """
    if any(a.flags.writeable for a in arrays):
        return make()
    store: OrderedDict[Hashable, tuple[tuple[FloatArray, ...], Any]]
    store = owner.__dict__.setdefault("_remembered", OrderedDict())
    k = (key, tuple(id(a) for a in arrays))  # the arrays are held below: ids stay unique
    hit = store.get(k)
    if hit is not None:
        store.move_to_end(k)
        return hit[1]
    value = make()
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    store[k] = (arrays, value)
    if len(store) > REMEMBERED:
        store.popitem(last=False)
    return value


def hold_interp(t_s: FloatArray, y: FloatArray, tq: FloatArray) -> FloatArray:
    """Interpolate ``y`` at ``tq``: linear, but held (zero-order) across jumps so that a step
    stays a step at the later sample instead of a one-sample ramp; held at the ends."""
    tq = np.clip(tq, t_s[0], t_s[-1])
    i = np.clip(np.searchsorted(t_s, tq, side="right") - 1, 0, t_s.size - 2)
    dt = t_s[i + 1] - t_s[i]
    frac = np.where(dt > 0, (tq - t_s[i]) / np.where(dt > 0, dt, 1.0), 0.0)
    dy = y[i + 1] - y[i]
    jumps = jump_intervals(y)
    out = y[i] + np.where(jumps[i], 0.0, frac) * dy
    return np.where(tq >= t_s[-1], y[-1], out)


def shift(t_s: FloatArray, y: FloatArray, delay_s: float, *, smooth: bool = False) -> FloatArray:
    """``y`` delayed by ``delay_s`` seconds: y(t - delay), held at the ends.

    ``hold_interp`` (linear, steps kept as steps), or with ``smooth`` a cubic spline (smooth in
    ``delay_s``, for coarse grids where a fitted shift must not stick to the sample times).
    """
    if not smooth:
        return hold_interp(t_s, y, t_s - delay_s)
    tq = np.clip(t_s - delay_s, t_s[0], t_s[-1])
    return np.asarray(CubicSpline(t_s, y)(tq), dtype=float)
