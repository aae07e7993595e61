"""The arm's colours (its links and joints; the screenshot looks for them), from the Okabe-Ito
palette, added to the shared palette on import."""

from __future__ import annotations

from viz.style import OKABE_ITO, RGB, register_colors

__all__ = ["CANVASES", "MANIPULATOR_COLORS", "READY_COLORS"]

MANIPULATOR_COLORS: dict[str, RGB] = {
    "arm_links": OKABE_ITO["bluish_green"],
    "arm_joints": OKABE_ITO["orange"],
    "arm_measured": (110, 110, 110),  # neutral grey (read on both themes): measured torque
    "arm_predicted": OKABE_ITO["vermillion"],  # the identified model's torque
}

#: Colours drawn together on one canvas: pairwise distinct.
CANVASES: dict[str, tuple[str, ...]] = {
    "arm": ("arm_links", "arm_joints"),
    "torque": ("arm_measured", "arm_predicted"),
}

#: Colours that only appear once the viewer has drawn the arm and its torque (the screenshot
#: waits for them). Only colours drawn flat: the links (3-D lines) and the predicted torque (a
#: plot line). The joints are 3-D points, which rerun shades as spheres: their exact orange
#: covers a few pixels or none, and the screenshot waited for it until its timeout.
READY_COLORS: tuple[str, ...] = ("arm_links", "arm_predicted")

register_colors(MANIPULATOR_COLORS)
