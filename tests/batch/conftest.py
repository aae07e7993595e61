"""Fixtures of the batch tests; the archive builders live in tests/batch_archive.py (a module
of its own name: ``from conftest import`` would find whichever conftest was imported first)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from batch_archive import FAST, full_archive

from logtools.batch.runner import BatchSummary, run_batch


@pytest.fixture(scope="session")
def archive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return full_archive(tmp_path_factory.mktemp("archive"))


@pytest.fixture(scope="session")
def batch_run(archive: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, BatchSummary]:
    """The full archive analysed once (2 workers, views on)."""
    out = tmp_path_factory.mktemp("out")
    options = dataclasses.replace(FAST, views=True)
    return out, run_batch(archive, out, options=options, workers=2)
