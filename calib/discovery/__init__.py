"""Model-mismatch discovery, one engine for every robot.

A robot declares its effects (:class:`EffectSpec`, each with the model hook its fitter calls)
in its catalogue, registers outside ones through an :class:`EffectRegistry`, and supplies a
:class:`Fitter`; the engine selects effects forward on held-out data (:func:`select_effects`),
models what the catalogue leaves out from the robot's own signals (``library``, ``sparse``,
``residual_model``), gives intervals that hold across the explanations (``explanations``) and
reports what it found in one shape (``report``). Parts, one module each: ``base`` (the protocols),
``registry``, ``selection``, ``library``, ``sparse``, ``residual_model``, ``explanations``,
``report``.
"""

from calib.discovery.base import (
    CandidateFailedError,
    EffectKind,
    EffectParam,
    EffectSpec,
    Fitter,
    ModelFit,
)
from calib.discovery.explanations import Explanation, Spanned, across, plausible
from calib.discovery.library import Family, Role, Signal, Term, build_library
from calib.discovery.registry import EffectRegistry
from calib.discovery.report import (
    Alternative,
    DiscoveryReport,
    FoundEffect,
    found_effects,
    moved_parameters,
    verdict_record,
)
from calib.discovery.residual_model import (
    DescribedTerm,
    DescribedTerms,
    Description,
    Entry,
    ResidualSpace,
    describe,
)
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
    "Alternative",
    "CandidateFailedError",
    "Checks",
    "Confound",
    "DescribedTerm",
    "DescribedTerms",
    "Description",
    "DiscoveryReport",
    "EffectKind",
    "EffectParam",
    "EffectRegistry",
    "EffectSpec",
    "Entry",
    "Explanation",
    "Family",
    "Fitter",
    "FoundEffect",
    "ModelFit",
    "ResidualSpace",
    "Role",
    "Round",
    "Selection",
    "SelectionRules",
    "Signal",
    "Spanned",
    "Term",
    "Tried",
    "across",
    "build_library",
    "describe",
    "found_effects",
    "heldout_gain",
    "moved_parameters",
    "plausible",
    "select_effects",
    "verdict_record",
]
