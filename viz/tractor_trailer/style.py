"""The tractor-trailer's colours (its points, links, curvature, joint angle and link lengths),
added to the shared palette on import; and the colours the screenshot test waits for."""

from __future__ import annotations

from viz.style import RGB, register_colors

__all__ = ["READY_COLORS", "TRACTOR_TRAILER_COLORS"]

TRACTOR_TRAILER_COLORS: dict[str, RGB] = {
    "C1": (230, 25, 75),  # red: front wheel centre
    "P": (255, 165, 0),  # orange: joint
    "C2": (0, 130, 200),  # blue: rear wheel centre
    "links": (240, 240, 240),
    "O": (60, 180, 75),  # green: instantaneous centre
    "Q": (145, 30, 180),  # purple
    "triangle_OQC2": (70, 240, 240),
    "triangle_QC1P": (240, 50, 230),
    "radius": (60, 180, 75),
    "kappa_cmd": (255, 225, 25),  # yellow
    "kappa": (255, 110, 40),  # orange-red
    "psi": (40, 80, 255),  # blue-violet
    "psi_estimate": (0, 210, 140),
    "psi_method": (200, 120, 255),
    "psi_steady": (255, 120, 190),  # pink: the steady-state relation
    "L1": (230, 25, 75),
    "L2": (0, 130, 200),
}

#: Colours that only appear once the viewer has drawn the data (not in its own UI): the world
#: view's C1 and C2 paths and the curvature plot. (The measured joint angle is drawn under the
#: recommended model's curve, so its colour may rightly cover almost nothing.)
READY_COLORS: tuple[str, ...] = ("C1", "C2", "kappa")

register_colors(TRACTOR_TRAILER_COLORS)
