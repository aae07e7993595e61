"""The differential drive's physical ranges for :mod:`calib.adequacy.plausibility`."""

from __future__ import annotations

from calib.adequacy.plausibility import PhysicalRange

__all__ = ["RANGES"]

_CAUSES = (
    "wheel angles logged in encoder ticks or degrees instead of radians, the wheels swapped or "
    "one counting backwards, or a pose in another unit (check the channel map and the wheels' "
    "ticks per revolution)"
)

RANGES = (
    PhysicalRange("wheel_radius_right", 0.005, 1.5, "m", _CAUSES),
    PhysicalRange("wheel_radius_left", 0.005, 1.5, "m", _CAUSES),
    PhysicalRange("track_width", 0.03, 5.0, "m", _CAUSES),
)
"""Wheel radii and tracks of real differential drives, from a desk robot's to a tractor's."""
