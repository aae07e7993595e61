"""Segmentation of a curvature command into template segments (see ``pipeline``).

Modules, in the order the pipeline uses them: ``preparation`` (checks, decimation, noise),
``change_points`` (jumps, binary segmentation), ``scoring`` (pieces and their BIC),
``merging``, ``refinement``, ``step_rule``; ``templates`` holds the template fits and
``settings`` the tuning.
"""

from calib.tractor_trailer.segmentation.pipeline import segment_command
from calib.tractor_trailer.segmentation.settings import SegmentationSettings
from calib.tractor_trailer.segmentation.templates import TemplateFit, fit_template

__all__ = ["SegmentationSettings", "TemplateFit", "fit_template", "segment_command"]
