"""Estimators beyond the patent's: EIV maximum likelihood of the steady-state relation, an
output-error fit of the transient kinematics, identifiability verdicts, and the recommendation.
"""

from calib.estimators.eiv import SteadyStateEIV
from calib.estimators.identifiability import IdentifiabilityVerdict, identifiability
from calib.estimators.recommend import calibrate_link_lengths
from calib.estimators.transient import TransientFit

__all__ = [
    "IdentifiabilityVerdict",
    "SteadyStateEIV",
    "TransientFit",
    "calibrate_link_lengths",
    "identifiability",
]
