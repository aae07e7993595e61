"""Differential-drive robot (two driven wheels, casters): kinematics, dead reckoning, odometry
calibration, skid-steer effective track, Gaussian path planning, PD tracking and a simulator.

Conventions (docs/diff_drive.md): body x forward, yaw counter-clockwise positive, the reference
point is the axle centre; ``wheel_right``/``wheel_left`` are cumulative wheel angles (rad,
positive forward); ``r_R``, ``r_L`` wheel radii (m); ``b`` the track width (m, wheel to wheel;
the 1997 paper's half-track is l_a = b / 2). The paper's wheel 1 is the right wheel and its body
y axis points forward; its Eqs. are rewritten here for x forward.
"""

from calib.diff_drive.dead_reckoning import DeadReckoning, dead_reckon
from calib.diff_drive.kinematics import (
    DiffDriveParams,
    control_point_inverse,
    control_point_velocity,
    forward,
    inverse,
)

__all__ = [
    "DeadReckoning",
    "DiffDriveParams",
    "control_point_inverse",
    "control_point_velocity",
    "dead_reckon",
    "forward",
    "inverse",
]
