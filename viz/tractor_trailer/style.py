"""The tractor-trailer's colours (its points, links, curvature, joint angle and link lengths),
from the Okabe-Ito palette, added to the shared palette on import; the colours drawn together
on one canvas; and the colours the screenshot test waits for."""

from __future__ import annotations

from viz.style import OKABE_ITO, RGB, register_colors

__all__ = ["CANVASES", "READY_COLORS", "TRACTOR_TRAILER_COLORS"]

_OI = OKABE_ITO

TRACTOR_TRAILER_COLORS: dict[str, RGB] = {
    "C1": _OI["vermillion"],  # front wheel centre
    "P": _OI["orange"],  # joint
    "C2": _OI["blue"],  # rear wheel centre
    "links": (100, 100, 100),  # neutral dark grey: read on the light and the dark theme
    "O": _OI["bluish_green"],  # instantaneous centre
    "Q": _OI["reddish_purple"],
    "triangle_OQC2": (171, 218, 244),  # sky blue half-mixed with white (kappa has the full one)
    "triangle_QC1P": (248, 242, 161),  # yellow half-mixed with white
    "radius": _OI["bluish_green"],  # from O, in O's colour
    "kappa_cmd": _OI["yellow"],
    "kappa": _OI["sky_blue"],
    "psi": _OI["blue"],
    "psi_estimate": _OI["bluish_green"],
    "psi_method": _OI["reddish_purple"],
    "psi_steady": _OI["orange"],  # the steady-state relation (not C1's vermillion: the viewer
    # screenshot tells panels apart by colour)
    "L1": _OI["vermillion"],
    "L2": _OI["blue"],
}

#: Colours drawn together on one canvas (a view or a figure's axes): pairwise distinct.
CANVASES: dict[str, tuple[str, ...]] = {
    "world": ("C1", "P", "C2", "links", "O", "Q", "triangle_OQC2", "triangle_QC1P"),
    "curvature": ("kappa_cmd", "kappa"),
    "joint angle": ("psi", "psi_estimate", "psi_method", "psi_steady"),
    "residuals": ("residual", "psi_estimate"),
    "lengths": ("L1", "L2"),
}

#: Colours that only appear once the viewer has drawn the data (not in its own UI): the world
#: view's C1 and C2 paths and the curvature plot. (The measured joint angle is drawn under the
#: recommended model's curve, so its colour may rightly cover almost nothing.)
READY_COLORS: tuple[str, ...] = ("C1", "C2", "kappa")

register_colors(TRACTOR_TRAILER_COLORS)
