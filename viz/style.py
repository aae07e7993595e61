"""Colours and names shared by the rerun recording, the PNG report and the screenshot test.

The shared palette holds only what every robot's views draw (a residual, the truth); each
robot declares the colours of its own things in its own room (``viz/<robot>/style.py``) and
adds them with :func:`register_colors`, so this module names no robot's signal.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["COLORS", "TIMELINE", "hex_color", "register_colors", "ui_points"]

#: Name of the rerun timeline: log time (absolute, ns) as ``datetime64[ns]``.
TIMELINE = "log_time"

RGB = tuple[int, int, int]

#: RGB colours (0-255) of the plotted things by name; saturated so a screenshot test can find
#: them. The shared ones here, each robot's added by :func:`register_colors`.
COLORS: dict[str, RGB] = {
    "residual": (220, 190, 255),
    "truth": (250, 250, 250),
}


def register_colors(colors: Mapping[str, RGB]) -> None:
    """Add a robot's colours to :data:`COLORS` (called once by its style module on import).

    Raises:
        ValueError: a name already has another colour (two robots naming one thing differently).
    """
    clash = sorted(n for n, rgb in colors.items() if COLORS.get(n, rgb) != rgb)
    if clash:
        raise ValueError(f"colours {', '.join(clash)} are registered with other values")
    COLORS.update(colors)


def hex_color(name: str) -> str:
    """The colour ``name`` as ``#rrggbb`` (for matplotlib)."""
    r, g, b = COLORS[name]
    return f"#{r:02x}{g:02x}{b:02x}"


def ui_points(points: float) -> float:
    """A radius in screen points: rerun reads a negative radius as UI points (the value
    ``rr.Radius.ui_points`` returns; spelled here as a float for the type checker)."""
    return -abs(points)
