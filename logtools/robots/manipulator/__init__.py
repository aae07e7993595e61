"""Serial arms (``manipulator``, n joints): dynamic parameters from joint logs.

Reads ``q1..qn`` and ``tau1..n`` (``/joint_states``), the joint names, and picks the model: the
URDF given by ``--urdf`` (``ManipulatorOptions.urdf``), the channel map's ``[robot] urdf`` or
the ``logcal`` metadata ``urdf`` (a path or an example-robot-data NAME), else the planar 2-link arm
when the metadata says ``model = planar2``.

This module only declares the plugin (signals, identification, aliases, view paths) and stays
light: every log's robot is resolved by loading all plugin declarations, so the analysis
(:mod:`.pipeline`, with :mod:`calib.manipulator`, scipy and pinocchio) and the report
(:mod:`.report`, rich) are named by import path (``lazy``) and imported on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from logtools.robots.base import RobotPlugin, SignalSpec, lazy
from logtools.robots.manipulator.options import ManipulatorOptions
from logtools.signals import RobotKey

if TYPE_CHECKING:
    from logtools.robots.base import Views
    from logtools.robots.info import InfoFn
    from logtools.robots.manipulator.info import info_section
    from viz.manipulator.views import log_views

__all__ = ["PLUGIN", "ManipulatorOptions"]


def _identify(signals: frozenset[str]) -> str | None:
    if "q1" in signals and "tau1" in signals:
        n = sum(1 for s in signals if s.startswith("q") and s[1:].isdigit())
        m = sum(1 for s in signals if s.startswith("tau") and s[3:].isdigit())
        return f"joint signals q1..q{n}, tau1..tau{m}"
    return None


PLUGIN = RobotPlugin(
    name="manipulator",
    title="serial arm (manipulator)",
    signals=(
        SignalSpec(
            "q",
            "rad",
            "joint positions (q1..qn; m for a prismatic joint)",
            required=True,
            per_element="position",
        ),
        SignalSpec(
            "qd",
            "rad/s",
            "joint velocities (not used: velocity is taken from q)",
            per_element="velocity",
        ),
        SignalSpec(
            "tau",
            "N·m",
            "joint torques (tau1..n; N for a prismatic joint)",
            required=True,
            per_element="effort",
        ),
    ),
    identify=_identify,
    analyze=lazy("logtools.robots.manipulator.pipeline:analyze_manipulator"),
    report=lazy("logtools.robots.manipulator.report:report_lines"),
    views="viz.manipulator.views:log_views",
    png="viz.manipulator.views:write_png",
    aliases=("manipulator_2link",),
    span_signals=("q", "tau"),
    options=ManipulatorOptions,
    info="logtools.robots.manipulator.info:info_section",
    simulate="logtools.robots.manipulator.commands:register_simulate",
    reproduce="logtools.robots.manipulator.commands:register_reproduce",
    robot_keys=(RobotKey("urdf", "a URDF path or a model name", text=True),),
)

if TYPE_CHECKING:  # the views and info hook named above fill their signatures (mypy only)
    _views: Views[ManipulatorOptions] = log_views
    _info: InfoFn = info_section
