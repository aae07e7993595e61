"""The patent's published figures (calib/tractor_trailer/data/patent_figures.json) and their
printed precision."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

__all__ = ["PublishedCell", "half_unit", "load_published"]


def half_unit(printed: str) -> float:
    """Half a unit in the last printed digit: "24.91" -> 0.005, "1150" -> 0.5, "-2.02e-8" ->
    5e-11 (the rounding interval of a correctly rounded print)."""
    mantissa, _, exponent = printed.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (-decimals) * 10.0 ** (int(exponent) if exponent else 0)


@dataclass(frozen=True)
class PublishedCell:
    """One printed number of the patent's Figs. 8–13.

    Attributes:
        figure: 8..13.
        cmd: curvature command "H", "C" or "L".
        method: row label as printed ("OLS1(EM1)", "TLS(EM1,2,3)", "OLS2(PM1)", ...).
        M: curvature amplitude (1/m).
        quantity: "dL1", "dL2" (m), "condition_number", "error_norm" (m), "a" (m), "b" (rad),
            "mu1", "cls_dL1_pct", "cls_dL2_pct" (%).
        printed: the number as printed; sigma: its printed σ (noisy figures) or None.
        misprint_of: the value the printed one should have been, where it is a misprint.
        note: why, where there is something to say.
    """

    figure: int
    cmd: str
    method: str
    M: float
    quantity: str
    printed: str
    sigma: str | None = None
    misprint_of: str | None = None
    note: str = ""

    @property
    def value(self) -> float:
        """The printed number."""
        return float(self.printed)

    @property
    def reference(self) -> float:
        """The number to compare with: the corrected value for a misprint."""
        return float(self.misprint_of or self.printed)

    @property
    def sigma_value(self) -> float:
        """Printed σ, NaN if none."""
        return float(self.sigma) if self.sigma is not None else math.nan


@cache
def _document() -> dict[str, Any]:
    text = (
        resources.files("calib.tractor_trailer")
        .joinpath("data/patent_figures.json")
        .read_text("utf-8")
    )
    return json.loads(text)


def load_published() -> tuple[tuple[PublishedCell, ...], dict[str, str]]:
    """All published cells and the figure titles (keyed by figure number as a string)."""
    doc = _document()
    cells = tuple(PublishedCell(**c) for c in doc["cells"])
    return cells, dict(doc["titles"])
