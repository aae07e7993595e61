"""The arm's colours (its links and joints; the screenshot looks for them), from the Okabe-Ito
palette, added to the shared palette on import."""

from __future__ import annotations

from viz.style import OKABE_ITO, RGB, register_colors

__all__ = ["CANVASES", "MANIPULATOR_COLORS", "READY_COLORS"]

MANIPULATOR_COLORS: dict[str, RGB] = {
    "arm_links": OKABE_ITO["bluish_green"],
    "arm_joints": OKABE_ITO["orange"],
    "arm_predicted": OKABE_ITO["vermillion"],  # the identified model's torque (report image)
}

#: Colours drawn together on one canvas: pairwise distinct.
CANVASES: dict[str, tuple[str, ...]] = {
    "arm": ("arm_links", "arm_joints"),
    "torque": ("residual", "arm_predicted"),
}

#: Colours that only appear once the viewer has drawn the arm (the screenshot waits for them).
READY_COLORS: tuple[str, ...] = ("arm_links", "arm_joints")

register_colors(MANIPULATOR_COLORS)
