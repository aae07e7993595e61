"""The differential drive's colours (its nominal and calibrated paths; the screenshot looks for
them), added to the shared palette on import."""

from __future__ import annotations

from viz.style import RGB, register_colors

__all__ = ["DIFF_DRIVE_COLORS"]

DIFF_DRIVE_COLORS: dict[str, RGB] = {
    "dd_nominal": (220, 60, 60),
    "dd_calibrated": (40, 120, 220),
}

register_colors(DIFF_DRIVE_COLORS)
