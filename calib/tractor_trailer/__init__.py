"""The patent's link-length calibration of the two-link robot: models, 36 methods, repeats."""

from calib.tractor_trailer.methods import (
    METHOD_NAMES,
    MethodEstimate,
    evaluate_methods,
    family_of,
)

__all__ = ["METHOD_NAMES", "MethodEstimate", "evaluate_methods", "family_of"]
