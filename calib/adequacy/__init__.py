"""Model adequacy, shared by every robot: does the model explain the log, where
does it not, and what that does to each number. Which physics explains it instead is the
discovery engine's (:mod:`calib.discovery`).

Arrays in, results out, like the rest of ``calib``. A robot hands in its residual channels
(:class:`ResidualChannel`) and gets an :class:`Adequacy` verdict (:func:`assess`), widens its
intervals under a misfit (:func:`under_misfit`) and tests its parameters for a change mid-log
(:func:`parameter_change`).
"""

from calib.adequacy.changes import PieceFit, parameter_change
from calib.adequacy.channel import ResidualChannel
from calib.adequacy.combine import combine_runs
from calib.adequacy.intervals import span, under_misfit, under_misfit_all
from calib.adequacy.locate import Location, locate
from calib.adequacy.noise import NoiseFloor, noise_floor
from calib.adequacy.plausibility import (
    Implausible,
    PhysicalRange,
    implausible,
    mark_implausible,
)
from calib.adequacy.stability import PieceStability, piece_stability, widen_unstable
from calib.adequacy.verdict import (
    EXPLAINS,
    EXPLAINS_RATIO,
    NOT_ASSESSED,
    NOT_EXPLAINED,
    Adequacy,
    ChannelAdequacy,
    ParameterChange,
    assess,
    not_assessed,
)

__all__ = [
    "EXPLAINS",
    "EXPLAINS_RATIO",
    "NOT_ASSESSED",
    "NOT_EXPLAINED",
    "Adequacy",
    "ChannelAdequacy",
    "Implausible",
    "Location",
    "NoiseFloor",
    "ParameterChange",
    "PhysicalRange",
    "PieceFit",
    "PieceStability",
    "ResidualChannel",
    "assess",
    "combine_runs",
    "implausible",
    "locate",
    "mark_implausible",
    "noise_floor",
    "not_assessed",
    "parameter_change",
    "piece_stability",
    "span",
    "under_misfit",
    "under_misfit_all",
    "widen_unstable",
]
