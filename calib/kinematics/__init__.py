"""Kinematics more than one robot shares (a shared room: the tractor of a tractor-trailer and a
car-like robot both steer by the bicycle model, :mod:`calib.kinematics.bicycle`)."""

from __future__ import annotations

from calib.kinematics.bicycle import (
    SteeringGeometry,
    bicycle_curvature,
    bicycle_yaw_rate,
    fit_steering_geometry,
)

__all__ = ["SteeringGeometry", "bicycle_curvature", "bicycle_yaw_rate", "fit_steering_geometry"]
