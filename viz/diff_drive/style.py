"""The differential drive's colours (its nominal and calibrated paths; the screenshot looks for
them), from the Okabe-Ito palette, added to the shared palette on import."""

from __future__ import annotations

from viz.style import OKABE_ITO, RGB, register_colors

__all__ = ["CANVASES", "DIFF_DRIVE_COLORS", "READY_COLORS"]

DIFF_DRIVE_COLORS: dict[str, RGB] = {
    "dd_nominal": OKABE_ITO["vermillion"],
    "dd_calibrated": OKABE_ITO["blue"],
}

#: Colours drawn together on one canvas: pairwise distinct.
CANVASES: dict[str, tuple[str, ...]] = {"paths": ("truth", "dd_nominal", "dd_calibrated")}

#: Colours that only appear once the viewer has drawn the paths (the screenshot waits for them).
READY_COLORS: tuple[str, ...] = ("dd_nominal", "dd_calibrated")

register_colors(DIFF_DRIVE_COLORS)
