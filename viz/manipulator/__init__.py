"""The arm's rerun views and report image."""

from viz.manipulator import style as _style  # noqa: F401  (adds the robot's colours)
