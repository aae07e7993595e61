"""Estimators beyond the patent's: EIV maximum likelihood of the steady-state relation, an
output-error fit of the transient kinematics, identifiability verdicts, and the recommendation.
"""

from calib.tractor_trailer.estimators.eiv import SteadyStateEIV
from calib.tractor_trailer.estimators.identifiability import IdentifiabilityVerdict, identifiability
from calib.tractor_trailer.estimators.recommend import calibrate_link_lengths
from calib.tractor_trailer.estimators.transient import TransientFit

__all__ = [
    "IdentifiabilityVerdict",
    "SteadyStateEIV",
    "TransientFit",
    "calibrate_link_lengths",
    "identifiability",
]
