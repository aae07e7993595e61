"""The differential drive's rerun views and report image."""

from viz.diff_drive import style as _style  # noqa: F401  (adds the robot's colours)
