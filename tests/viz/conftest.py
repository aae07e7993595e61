"""Fixtures of the viz tests; the cases are built in tests/viz_cases.py (a module of its own
name, so that tests import it unambiguously)."""

from __future__ import annotations

from dataclasses import replace

import pytest
from viz_cases import VizCase, make_result, simulate, views_for

from calib.tractor_trailer.views_data import VIEWS


@pytest.fixture(scope="session")
def case() -> VizCase:
    run = simulate()
    result = make_result(run)
    return VizCase(run.truth, replace(result, artifacts={VIEWS: views_for(run.truth, result)}))
