"""indgen: an INDEPENDENT generator of tractor-trailer drive logs, for tests and statistical
studies. It shares no code with the code under test (nothing from ``calib``, ``logtools`` or
``viz`` is imported): numpy, scipy, mcap, mcap_ros2 and rosbags only.

Physics (state of C1, the no-side-slip reference point of the tractor: x, y, heading th1; the
hitch angle psi = th1 - th2, th2 the trailer heading):

    x' = v cos th1,  y' = v sin th1,  th1' = v kappa,
    psi' = v kappa - (v sin psi - L1 v kappa cos psi) / L2  [- c v^2 kappa with trailer slip]

L1: distance from C1 back to the hitch P (> 0 behind the axle, < 0 ahead of it); L2: hitch to
trailer axle C2. P = C1 - L1 (cos th1, sin th1), C2 = P - L2 (cos th2, sin th2). Steady state:
sin psi = kappa (L2 + L1 cos psi); psi > 0 when turning left (kappa > 0). Solved with DOP853
(rtol 1e-10, atol 1e-12, dense output) piecewise between input discontinuities; every sensor
is evaluated at its own true sample instants.

Effects and signs (same meaning as calib/tractor_trailer/discovery/effects; truth keys and
parameter names
match calib's catalogue keys, e.g. ``sensor_offset(psi)`` -> {"offset": b}):

- ``actuator_delay`` {delay: d} (s): kappa(t) = kappa_cmd(t - d) (the command before t = 0 is
  held at its t = 0 value).
- ``actuator_lag`` {time_constant: tau} (s): tau kappa' = kappa_cmd(t - d) - kappa, an ODE
  state starting at rest at the command.
- ``understeer`` {K} (s^2/m^2): kappa = kappa_lagged / (1 + K v^2), v the actual speed
  (applied after delay and lag, as in calib's stage-0 order delay, lag, understeer).
- ``sensor_offset(sig)`` {offset}: recorded = true + offset (sig a signal: psi, omega, v, ...).
- ``sensor_scale(sig)`` {scale}: recorded = scale * true (before the offset is added).
- ``clock_offset(group)`` {offset: c} (s): the group's stamps = true instant + c (c > 0: the
  topic is stamped late; recorded(t) = true(t - c)).
- ``trailer_slip`` {c} (s/m), outside calib's catalogue: psi' gets -c v^2 kappa (the steady
  hitch angle shrinks with speed: small-angle psi ~ kappa (L1 + L2 - c v L2)); the trailer
  axle then slips sideways.
- ``drive_gain`` (Scenario field, truth["drive_gain"]): actual speed = gain * commanded speed.

Robots: ``tractor_trailer`` (curvature commands; LOG_FORMAT.md topics /cmd/curvature,
/cmd/vel, /odom, /pose, /hitch/angle) and ``small_tractor_trailer`` (a small ROS 2 robot:
steered drive wheel, wheelbase 0.42 m, kappa = tan(delta)/0.42 at the rear axle, L1 = -0.02,
L2 = 0.537; topics /cmd_vel (linear.x speed, angular.z steering angle), /encoder/angle,
/odom (trailer C2 pose from motion capture, zero twist), /truck_trailer/truck_pose,
/kelo_angle (measured steering angle), /tf map->truck_link). The speed on /cmd_vel is the
commanded speed of the rear-axle reference point C1.

Other robots (``robots.generate_log``): a differential drive (``diffdrive``), a planar 2-link
arm with its URDF (``arm``) and the tractor-trailer with catalogue-escaping physics
(``tractor_kinds``); the kinds and the three held-out ones are in ``kinds``; logs are
``robotlog.RobotLog`` written by ``robot_writers`` (JSON MCAP, CSV), with the effect size of the
kind in ``truth["effect_size"]``.

Usage::

    rng = np.random.default_rng(1)
    scn = random_scenario(rng, effects=("actuator_delay",), L1=1.25, L2=2.48)
    gen = generate(scn, seed=7)
    write_mcap_json("a.mcap", gen); gen.truth["effects"]  # {"actuator_delay": {"delay": ...}}
"""

from .generate import Generated, TopicData, generate
from .inputs import Command, Speed
from .kinds import HELD_OUT_KINDS, KINDS, KindDef, kinds_of
from .physics import Trajectory, integrate
from .robot_writers import write_log
from .robotlog import RobotLog, Stream, effect_size
from .robots import generate_log
from .scenario import (
    EFFECT_NAMES,
    SMALL_ROBOT,
    TOPICS,
    Effects,
    Scenario,
    TopicDef,
    TopicSpec,
    random_scenario,
    small_robot_scenario,
)
from .writers import (
    CSV_COLUMNS,
    ROS_TYPES,
    write_csv,
    write_mcap_json,
    write_mcap_ros2,
    write_rosbag1,
    write_rosbag2,
)

__all__ = [
    "CSV_COLUMNS",
    "EFFECT_NAMES",
    "HELD_OUT_KINDS",
    "KINDS",
    "ROS_TYPES",
    "SMALL_ROBOT",
    "TOPICS",
    "Command",
    "Effects",
    "Generated",
    "KindDef",
    "RobotLog",
    "Scenario",
    "Speed",
    "Stream",
    "TopicData",
    "TopicDef",
    "TopicSpec",
    "Trajectory",
    "effect_size",
    "generate",
    "generate_log",
    "integrate",
    "kinds_of",
    "random_scenario",
    "small_robot_scenario",
    "write_csv",
    "write_log",
    "write_mcap_json",
    "write_mcap_ros2",
    "write_rosbag1",
    "write_rosbag2",
]
