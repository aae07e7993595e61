"""The tractor-trailer's rerun views and report image: world and instantaneous-centre
construction, signals, method error bars, fits and residuals."""

from viz.tractor_trailer import style as _style  # noqa: F401  (adds the robot's colours)
