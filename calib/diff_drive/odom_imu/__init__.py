"""What a log of wheel odometry, an IMU and maybe GPS determines (the usual ROS log of a Husky,
a Jackal, most mobile robots): no encoder angles, no ground-truth pose.

* **Yaw-rate gain** G = odometry yaw rate / gyro yaw rate. The controller's odometry turns
  the wheel speeds into a yaw rate with the geometric track; a skid steer turns slower, so
  G = b_effective / b_geometric (> 1) and the effective track is the geometric one x G. Fitted
  on windows of ``WINDOW_S`` (the gyro's yaw change = odometry's yaw change / G + bias x
  duration; a gyro bias is always fitted), at the lag that best aligns the two (found by
  cross-correlation within ``MAX_LAG_S``). 95 % interval: moving-block bootstrap over windows,
  value ± t std on (blocks - 1) degrees of freedom.
* **Its dependence on turn rate and speed**: G per bin of |odometry yaw rate| and of speed.
* **Distance scale** against GPS (when the log has a fix): GPS distance / odometry distance
  over windows of ``GPS_WINDOW_S`` while moving.
* **Adequacy**: the gyro's yaw-change residual of the constant-gain model (held out: two folds
  of alternating time blocks), located by turn rate and speed; **discovery** through
  :func:`calib.discovery.select_effects` with ``turn_slip`` (G grows with |turn rate|: the wheels
  slide more the faster the robot turns), ``speed_slip`` (G grows with speed) and ``icr_slip``
  (the ICR model of a skid steer: G grows jointly with speed and turn rate). Each
  effect's hook (a :class:`GainEffectModel`) says what it adds to the gain
  G = (1 + sum of constant parts) (1 + sum of growth parts); the fitter never reads an id.

Parts: ``windows`` (the log cut into windows, the lag), ``gain`` (the constant gain, its
bootstrap, bins and misfit widening), ``effects`` (the catalogue), ``fitter`` (discovery's
fitter), ``gps`` (the distance scale), ``result`` (the result and its report), ``analysis``
(the whole analysis).
"""

from calib.diff_drive.odom_imu.analysis import analyze_odom_imu
from calib.diff_drive.odom_imu.effects import (
    GAIN,
    ICR_SLIP,
    SPEED_SLIP,
    TURN_SLIP,
    GainEffectModel,
)
from calib.diff_drive.odom_imu.result import OdomImuResult

__all__ = [
    "GAIN",
    "ICR_SLIP",
    "SPEED_SLIP",
    "TURN_SLIP",
    "GainEffectModel",
    "OdomImuResult",
    "analyze_odom_imu",
]
