"""Reproductions of published results: the patent's Figs. 8–13 (``reproduce_patent``)."""

from calib.tractor_trailer.reproduce.patent import (
    FigureCell,
    FigureTable,
    PatentReproduction,
    SplitRow,
    reproduce_patent,
)
from calib.tractor_trailer.reproduce.scenario import PATENT_SCENARIO, PatentScenario

__all__ = [
    "PATENT_SCENARIO",
    "FigureCell",
    "FigureTable",
    "PatentReproduction",
    "PatentScenario",
    "SplitRow",
    "reproduce_patent",
]
