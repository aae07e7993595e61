"""sample_logs/: small, readable, and what `python -m logtools.sample_logs` regenerates."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader

from logtools.readers import read_log
from logtools.robots.tractor_trailer.samples import SAMPLES, SampleLog
from logtools.sample_logs import main, write_sample_logs

pytestmark = pytest.mark.slow  # regenerates every sample log (~7 s)

SAMPLE_DIR = Path(__file__).resolve().parents[2] / "sample_logs"


def _records(path: Path) -> list[tuple[str, int, bytes]]:
    if path.suffix == ".csv":
        return [("csv", i, line) for i, line in enumerate(path.read_bytes().splitlines())]
    with path.open("rb") as fh:
        return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(fh).iter_messages()]


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("samples")
    write_sample_logs(out)
    return out


@pytest.mark.parametrize("sample", SAMPLES, ids=lambda s: s.name)
def test_committed_sample_is_current_and_small(sample: SampleLog, regenerated: Path) -> None:
    committed = SAMPLE_DIR / sample.name
    assert committed.stat().st_size < 2_000_000
    assert _records(committed) == _records(regenerated / sample.name)
    log = read_log(committed)
    assert log.problems == []
    if sample.encoding != "csv":
        assert log.metadata["logcal"]["L1"] == "1.25"
        assert log.metadata["logcal"]["preset"] == sample.preset


def test_readme_lists_every_sample_and_the_command() -> None:
    text = (SAMPLE_DIR / "README.md").read_text()
    assert "python -m logtools.sample_logs" in text
    for sample in SAMPLES:
        assert sample.name in text


def test_main_prints_paths(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert all(str(tmp_path / s.name) in out for s in SAMPLES)
