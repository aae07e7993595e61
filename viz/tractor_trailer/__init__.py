"""The tractor-trailer's rerun views and report image: world and instantaneous-centre
construction, signals, method error bars, fits and residuals."""
