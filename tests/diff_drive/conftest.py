"""Fixtures of the differential-drive tests: the plugin registered, real recordings' paths."""

from __future__ import annotations

from pathlib import Path

import pytest

REAL = Path(__file__).resolve().parents[3] / "shared" / "realworld_drive" / "optiodom"
if not REAL.is_dir():
    REAL = Path("/work/shared/realworld_drive/optiodom")


@pytest.fixture(autouse=True, scope="session")
def _diff_drive_plugin() -> None:
    """Register the plugin (a no-op once the lead lists it in logtools.robots)."""
    from logtools.robots import plugins, register
    from logtools.robots.diff_drive import PLUGIN

    if not any(p.name == "diff_drive" for p in plugins()):
        register(PLUGIN)


@pytest.fixture
def square_run() -> Path:
    path = REAL / "square" / "231220200029" / "231220200029_run-01.csv"
    if not path.is_file():
        pytest.skip("the real recordings in ../shared/realworld_drive are not available")
    return path
