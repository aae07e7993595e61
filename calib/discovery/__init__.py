"""Model-mismatch discovery, one engine for every robot.

A robot declares its effects (:class:`EffectSpec`, each with the model hook its fitter calls)
in its catalogue, registers outside ones through an :class:`EffectRegistry`, and supplies a
:class:`Fitter`; the engine selects effects forward on held-out data (:func:`select_effects`),
and reports what it found. Parts, one module each: ``base`` (the protocols), ``registry``,
``selection``.
"""

from calib.discovery.base import (
    CandidateFailedError,
    EffectKind,
    EffectParam,
    EffectSpec,
    Fitter,
    ModelFit,
)
from calib.discovery.registry import EffectRegistry
from calib.discovery.selection import (
    BIC_MARGIN,
    MIN_HELDOUT_GAIN,
    Checks,
    Confound,
    Round,
    Selection,
    SelectionRules,
    Tried,
    heldout_gain,
    select_effects,
)

__all__ = [
    "BIC_MARGIN",
    "MIN_HELDOUT_GAIN",
    "CandidateFailedError",
    "Checks",
    "Confound",
    "EffectKind",
    "EffectParam",
    "EffectRegistry",
    "EffectSpec",
    "Fitter",
    "ModelFit",
    "Round",
    "Selection",
    "SelectionRules",
    "Tried",
    "heldout_gain",
    "select_effects",
]
