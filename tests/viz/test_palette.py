"""The colours are the Okabe-Ito palette's (told apart with colour-vision deficiencies), tints
of them or neutral greys, and the colours drawn on one canvas are distinct (each robot declares
its canvases in its style module)."""

from __future__ import annotations

import itertools

import pytest

from viz.diff_drive import style as dd_style
from viz.manipulator import style as arm_style
from viz.style import COLORS, OKABE_ITO
from viz.tractor_trailer import style as tt_style

STYLES = {"tractor_trailer": tt_style, "diff_drive": dd_style, "manipulator": arm_style}


def _neutral(rgb: tuple[int, int, int]) -> bool:
    return max(rgb) - min(rgb) <= 10


def _tint_of(rgb: tuple[int, int, int], base: tuple[int, int, int]) -> bool:
    """``rgb`` = ``base`` mixed with white (one mixing fraction for the three channels, +-4)."""
    fractions = [(c - b) / (255 - b) for c, b in zip(rgb, base, strict=True) if b < 250]
    return bool(fractions) and max(fractions) - min(fractions) <= 0.06 and min(fractions) > 0


def test_every_colour_is_okabe_ito_a_tint_or_neutral() -> None:
    palette = set(OKABE_ITO.values())
    for name, rgb in COLORS.items():
        ok = rgb in palette or _neutral(rgb) or any(_tint_of(rgb, b) for b in palette)
        assert ok, (name, rgb)


@pytest.mark.parametrize("robot", sorted(STYLES))
def test_colours_on_one_canvas_are_distinct(robot: str) -> None:
    for canvas, names in STYLES[robot].CANVASES.items():
        for a, b in itertools.combinations(names, 2):
            gap = max(abs(x - y) for x, y in zip(COLORS[a], COLORS[b], strict=True))
            assert gap > 40, (canvas, a, b)


@pytest.mark.parametrize("robot", sorted(STYLES))
def test_ready_colours_are_used_once_on_their_canvas(robot: str) -> None:
    """The screenshot finds a ready colour by its pixels: nothing else on its canvas shares it."""
    style = STYLES[robot]
    for name in style.READY_COLORS:
        assert name in COLORS
        shared = [
            other
            for names in style.CANVASES.values()
            if name in names
            for other in names
            if other != name and COLORS[other] == COLORS[name]
        ]
        assert not shared, (name, shared)
