"""Regenerate the patent's Figs. 8–13 beside the published numbers, and the CLS split table.

Ideal-data figures (8, 10, 11) are compared to the printed precision (half a unit in the last
printed digit); noisy ones (12, 13) to the printed σ (or the printed precision if larger);
Fig. 9 (EMLS on noisy data, ill-conditioned, no σ printed) by order of magnitude and ranking.
Statuses: "ok", "outside", "round-off" (an ideal-data intercept below 1e-6 rad on both sides:
floating-point residue, not a property of the data), "order" (Fig. 9: within a factor 10).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from calib.results import json_safe
from calib.tractor_trailer.methods import (
    CLS_TABLE,
    METHOD_NAMES,
    MethodEstimate,
    evaluate_methods,
)
from calib.tractor_trailer.patent_models import ExactModel
from calib.tractor_trailer.repeats import methods_over_repeats
from calib.tractor_trailer.reproduce.published import PublishedCell, half_unit, load_published
from calib.tractor_trailer.reproduce.scenario import COMMANDS, PATENT_SCENARIO, PatentScenario
from calib.tractor_trailer.results import MethodResult

__all__ = [
    "FigureCell",
    "FigureTable",
    "PatentReproduction",
    "SplitRow",
    "reproduce_patent",
]

ROUND_OFF_RAD = 1e-6
# CLS method whose error is shown beside each PM fit (the PM's LS + OLS1(EM1)), read from
# patent Table 3 (``CLS_TABLE``): "OLS1(PM2)" -> "M1", ..., "TLS(PM1)" -> "M21".
CLS_FOR_PM = {
    f"{s.pm_solver}({s.pm})": s.name
    for s in CLS_TABLE.values()
    if s.em_solver == "OLS1" and s.em is ExactModel.EM1
}
NOISY_NAMES = tuple(n for n in METHOD_NAMES if not n.startswith("M"))
SPLIT_TRUTHS = ((1.25, 2.48), (1.8, 1.8), (0.5, 3.2), (1.865, 1.865), (0.5, 3.23), (2.5, 1.23))
SPLIT_METHODS = ("M1", "M13", "M17", "M24")


@dataclass(frozen=True)
class FigureCell:
    """One reproduced number beside the published one.

    Attributes:
        published: the printed cell. ours: our value (mean over repeats for noisy figures).
        ours_std: our σ over repeats (NaN for ideal data). deviation: ours − reference.
        tolerance: what counts as agreement (NaN for Fig. 9). status: see module docstring.
    """

    published: PublishedCell
    ours: float
    ours_std: float
    deviation: float
    tolerance: float
    status: str

    def to_dict(self) -> dict[str, Any]:
        p = self.published
        return json_safe(
            {
                "figure": p.figure,
                "cmd": p.cmd,
                "method": p.method,
                "M": p.M,
                "quantity": p.quantity,
                "ours": self.ours,
                "ours_std": self.ours_std,
                "published": p.value,
                "published_text": p.printed,
                "published_sigma": p.sigma_value,
                "misprint_of": None if p.misprint_of is None else float(p.misprint_of),
                "deviation": self.deviation,
                "tolerance": self.tolerance,
                "status": self.status,
                "note": p.note,
            }
        )


@dataclass(frozen=True)
class FigureTable:
    """All cells of one figure, with a summary and notes."""

    figure: int
    title: str
    noisy: bool
    cells: tuple[FigureCell, ...]
    notes: tuple[str, ...] = ()

    def counts(self) -> dict[str, int]:
        """Number of cells per status."""
        out: dict[str, int] = {}
        for c in self.cells:
            out[c.status] = out.get(c.status, 0) + 1
        return out

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "figure": self.figure,
                "title": self.title,
                "noisy": self.noisy,
                "counts": self.counts(),
                "notes": list(self.notes),
                "cells": [c.to_dict() for c in self.cells],
            }
        )


@dataclass(frozen=True)
class SplitRow:
    """A CLS estimate for one true (L1, L2) split (m); ``noisy_*`` over repeats of M17."""

    L1_true: float
    L2_true: float
    method: str
    L1: float
    L2: float

    @property
    def split(self) -> float:
        """Estimated L1 / (L1 + L2)."""
        return self.L1 / (self.L1 + self.L2)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "L1_true": self.L1_true,
                "L2_true": self.L2_true,
                "method": self.method,
                "L1": self.L1,
                "L2": self.L2,
                "split_true": self.L1_true / (self.L1_true + self.L2_true),
                "split": self.split,
            }
        )


@dataclass(frozen=True)
class PatentReproduction:
    """``logcal reproduce patent``: every figure, the CLS split table, the set-up."""

    figures: tuple[FigureTable, ...]
    split_rows: tuple[SplitRow, ...]
    split_setting: str
    scenario: PatentScenario
    repeats: int
    seed: int
    notes: tuple[str, ...] = field(default_factory=tuple)

    def figure(self, number: int) -> FigureTable:
        """The table of Fig. ``number``."""
        return next(f for f in self.figures if f.figure == number)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "scenario": self.scenario.to_dict(),
                "repeats": self.repeats,
                "seed": self.seed,
                "notes": list(self.notes),
                "figures": [f.to_dict() for f in self.figures],
                "cls_split": {
                    "setting": self.split_setting,
                    "rows": [r.to_dict() for r in self.split_rows],
                },
            }
        )


def _our_name(method: str) -> str:
    return "TLS(EM1)" if method == "TLS(EM1,2,3)" else method


def _ideal_value(cell: PublishedCell, est: dict[str, MethodEstimate], sc: PatentScenario) -> float:
    e = est[_our_name(cell.method)]
    q = cell.quantity
    if q == "dL1":
        return e.L1 - sc.L1
    if q == "dL2":
        return e.L2 - sc.L2
    if q == "condition_number":
        return e.condition_number
    if q in ("a", "b", "mu1"):
        return e.extra.get(q, math.nan)
    if q.startswith("cls_"):
        cls = est[CLS_FOR_PM[cell.method]]
        return 100.0 * ((cls.L1 / sc.L1 - 1.0) if q == "cls_dL1_pct" else (cls.L2 / sc.L2 - 1.0))
    raise ValueError(f"figure {cell.figure}: unknown quantity {q!r}")


def _noisy_value(
    cell: PublishedCell, res: dict[str, MethodResult], sc: PatentScenario
) -> tuple[float, float]:
    r = res[_our_name(cell.method)]
    q = cell.quantity
    if q == "error_norm":
        return float(math.hypot(r.L1 - sc.L1, r.L2 - sc.L2)), math.nan
    if q == "condition_number":
        return r.condition_number, r.condition_number_std
    return r.extra.get(q, math.nan), r.extra.get(f"{q}_std", math.nan)


def _status(cell: PublishedCell, ours: float) -> tuple[float, float, str]:
    ref = cell.reference
    dev = ours - ref
    if cell.figure == 9:
        ratio = ours / ref if ref else math.inf
        ok = math.isfinite(ratio) and 0.1 <= ratio <= 10.0
        return dev, math.nan, "order" if ok else "outside"
    tol = half_unit(cell.misprint_of or cell.printed)
    if cell.sigma is not None:
        tol = max(tol, cell.sigma_value)
    if (
        cell.sigma is None
        and cell.quantity == "b"
        and abs(ref) < ROUND_OFF_RAD
        and abs(ours) < ROUND_OFF_RAD
        and abs(dev) > tol
    ):
        return dev, tol, "round-off"
    ok = math.isfinite(dev) and abs(dev) <= tol * (1.0 + 1e-9)
    return dev, tol, "ok" if ok else "outside"


def _fig9_notes(cells: Iterable[FigureCell]) -> tuple[str, ...]:
    notes = []
    groups: dict[tuple[str, float], list[FigureCell]] = {}
    for c in cells:
        groups.setdefault((c.published.cmd, c.published.M), []).append(c)
    for (cmd, M), cs in groups.items():
        ours = [c.published.method for c in sorted(cs, key=lambda c: c.ours)]
        pub = [c.published.method for c in sorted(cs, key=lambda c: c.published.value)]
        same = "same" if ours == pub else "different"
        notes.append(
            f"{cmd}, M={M}: ranking (smallest error first) ours {', '.join(ours)}; "
            f"published {', '.join(pub)} ({same})"
        )
    return tuple(notes)


FIGURE_NOTES = {
    9: (
        "EMLS on noisy data is ill-conditioned, so a 10-repeat mean is dominated by a few "
        "repeats and no σ is printed: compared by order of magnitude ('≈': within a factor "
        "10) and by ranking, not tuned. Over seeds 0-5 (measured when this was written), "
        "OLS1(EM1) and TLS(EM1,2,3) land within about 25 % of the printed values, OLS1(EM2) "
        "changes by factors of several from seed to seed, and OLS1(EM3) at M = 0.2 comes out "
        "3-30x below the printed values.",
    ),
    10: (
        "CLS errors are those of M1/M5/M9 (the PM fit + OLS1(EM1)); M2-M4 etc. agree with "
        "them to the printed precision. Intercepts printed as 1e-8..1e-12 are round-off "
        "('~'): both sides are zero to the precision of the fit.",
    ),
    11: ("CLS errors are those of M13/M17/M21 (the PM fit + OLS1(EM1)).",),
    12: (
        "Fig. 12 prints 2.42 for L, OLS1(PM2), M=0.1: a misprint of 3.42 (see the cell's "
        "note); it is compared with 3.42, not matched.",
        "Several published noisy condition numbers contradict the patent's own ideal-data "
        "Fig. 10 (C, TLS(PM2), M=0.2: 1.10±0.08 noisy vs 3.51 ideal; H, OLS2(PM2), M=0.1: "
        "14.74±3.87 vs 3.80); with the documented noise ours stay within about 20 % of the ideal "
        "values. These cells are reported as outside, not tuned to.",
    ),
}


def _figure_tables(
    ideal: dict[tuple[str, float], dict[str, MethodEstimate]],
    noisy: dict[tuple[str, float], dict[str, MethodResult]],
    sc: PatentScenario,
) -> tuple[FigureTable, ...]:
    cells, titles = load_published()
    tables = []
    for number in (8, 9, 10, 11, 12, 13):
        is_noisy = number in (9, 12, 13)
        out = []
        for cell in (c for c in cells if c.figure == number):
            key = (cell.cmd, cell.M)
            if is_noisy:
                ours, ours_std = _noisy_value(cell, noisy[key], sc)
            else:
                ours, ours_std = _ideal_value(cell, ideal[key], sc), math.nan
            dev, tol, status = _status(cell, ours)
            out.append(FigureCell(cell, ours, ours_std, dev, tol, status))
        notes = FIGURE_NOTES.get(number, ()) + (_fig9_notes(out) if number == 9 else ())
        tables.append(FigureTable(number, titles[str(number)], is_noisy, tuple(out), notes))
    return tuple(tables)


def _split_rows(sc: PatentScenario, cmd: str, M: float) -> tuple[SplitRow, ...]:
    rows = []
    for L1, L2 in SPLIT_TRUTHS:
        k, p = sc.ideal(cmd, M, L1, L2)
        est = evaluate_methods(k, p, SPLIT_METHODS)
        rows += [SplitRow(L1, L2, n, est[n].L1, est[n].L2) for n in SPLIT_METHODS]
    return tuple(rows)


def reproduce_patent(
    *, repeats: int = 10, seed: int = 0, scenario: PatentScenario = PATENT_SCENARIO
) -> PatentReproduction:
    """Recompute the patent's Figs. 8–13 and compare them with the published numbers.

    Args:
        repeats: noisy repeats per command and amplitude (the patent: 10).
        seed: seed of the noise (``np.random.default_rng(seed)``).
        scenario: the simulation set-up (default: the patent's, see ``scenario``).

    Returns:
        A ``PatentReproduction`` (``to_dict()`` is the ``--json`` document).

    Raises:
        ValueError: repeats < 1.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    rng = np.random.default_rng(seed)
    ideal: dict[tuple[str, float], dict[str, MethodEstimate]] = {}
    noisy: dict[tuple[str, float], dict[str, MethodResult]] = {}
    for cmd in COMMANDS:
        for M in scenario.amplitudes:
            ideal[(cmd, M)] = evaluate_methods(*scenario.ideal(cmd, M))
            rows = methods_over_repeats(
                scenario.noisy(cmd, M, repeats=repeats, rng=rng), names=NOISY_NAMES
            )
            noisy[(cmd, M)] = {r.name: r for r in rows}
    split_cmd, split_M = "H", max(scenario.amplitudes)
    return PatentReproduction(
        figures=_figure_tables(ideal, noisy, scenario),
        split_rows=_split_rows(scenario, split_cmd, split_M),
        split_setting=(
            f"ideal data, command {split_cmd}, M = {split_M} 1/m: CLS estimates for true "
            "splits with (about) the same sum; the estimated L1/(L1+L2) stays near 1/3"
        ),
        scenario=scenario,
        repeats=repeats,
        seed=seed,
        notes=(
            "Time grid and noise of the scenario: see calib.tractor_trailer.reproduce.scenario "
            "(630 samples over [0, 63] s for H and C, [0, 20 pi] s for L; Gaussian sigma "
            "0.03/sqrt(3) on kappa and psi).",
            "CLS weakness: the PM step puts the data on a straight line, where the L1/L2 split "
            "comes from the Taylor expansion of sin and cos, not from the robot: see cls_split.",
        ),
    )
