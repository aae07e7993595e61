"""The tractor-trailer's physical ranges for :mod:`calib.adequacy.plausibility`."""

from __future__ import annotations

from calib.adequacy.plausibility import PhysicalRange

__all__ = ["RANGES"]

_CAUSES = (
    "the joint angle logged in degrees (read as radians) or with the wrong sign, another "
    "signal mapped to psi, or a pose of link 2 taken for link 1's (check --signal and the "
    "channel map)"
)

RANGES = (
    PhysicalRange("L1", -3.0, 15.0, "m", _CAUSES),
    PhysicalRange("L2", 0.1, 30.0, "m", _CAUSES),
    PhysicalRange("sum_L1_L2", 0.1, 40.0, "m", _CAUSES),
)
"""Hitch offsets and drawbar lengths of real tractors and trailers, from a small robot's
(L1 a few centimetres either side of the axle, L2 half a metre) to a semi-trailer's."""
