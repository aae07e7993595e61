"""The colours are the Okabe-Ito palette's (told apart with colour-vision deficiencies), tints
of them or neutral greys, and the colours drawn on one canvas are distinct."""

from __future__ import annotations

import itertools

from viz.style import CANVASES, COLORS, OKABE_ITO, READY_COLORS


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


def test_colours_on_one_canvas_are_distinct() -> None:
    for canvas, names in CANVASES.items():
        for a, b in itertools.combinations(names, 2):
            gap = max(abs(x - y) for x, y in zip(COLORS[a], COLORS[b], strict=True))
            assert gap > 40, (canvas, a, b)


def test_ready_colours_are_used_once_on_their_canvas() -> None:
    """The screenshot finds a ready colour by its pixels: nothing else on its view shares it."""
    tractor = set(CANVASES["tractor world"]) | set(CANVASES["curvature"])
    for name in READY_COLORS["tractor_trailer"]:
        others = [n for n in tractor if n != name and COLORS[n] == COLORS[name]]
        assert not others, (name, others)
