"""logcal physics models, simulators, least squares, estimators and discovery (no I/O)."""
