"""The tractor-trailer's discovery baseline is one of its declared options
(``TractorTrailerOptions.baseline``): ``analyze``, ``view`` and ``batch`` offer ``--baseline``
from the declaration, a ``logcal.toml`` names it by key, and the batch's command line wins over
the settings file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from calib.tractor_trailer.results import Baseline
from logtools.batch.archive import LogJob
from logtools.batch.runner import BatchSummary
from logtools.batch.settings import SettingsError, settings_for
from logtools.batch.worker import AnalysisOptions, analyse_job
from logtools.cli.main import main
from logtools.errors import LogcalInputError
from logtools.robot_options import option, option_specs
from logtools.robots import plugin_for
from logtools.robots.tractor_trailer.options import TractorTrailerOptions


def test_baseline_is_declared_by_the_tractor_trailer_only() -> None:
    spec = {s.key: s for s in option_specs(plugin_for("tractor_trailer"))}["baseline"]
    assert (spec.flag, spec.type, spec.view, spec.batch) == ("--baseline", Baseline, True, True)
    assert spec.metavar == "transient|steady"
    for other in ("diff_drive", "manipulator"):
        assert "baseline" not in {s.key for s in option_specs(plugin_for(other))}
    assert TractorTrailerOptions().baseline is None  # not given: the pipeline's transient


def test_batch_takes_only_options_declared_for_it(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["batch", "-h"]) == 0
    text = capsys.readouterr().out
    assert "--baseline transient|steady" in text
    assert "--discovery-span" not in text
    assert "--urdf" not in text
    with pytest.raises(ValueError, match="batch=True"):
        option(flag="--map", help="a file", file=True, batch=True)


def test_batch_hands_the_given_baseline_to_every_log(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen: list[AnalysisOptions] = []

    def fake_run_batch(
        archive: Path, out: Path, *, options: AnalysisOptions, **_: Any
    ) -> BatchSummary:
        seen.append(options)
        return BatchSummary(out=out, logs=0)

    monkeypatch.setattr("logtools.batch.runner.run_batch", fake_run_batch)
    (tmp_path / "a").mkdir()
    args = ["batch", str(tmp_path / "a"), "--out", str(tmp_path / "out")]
    assert main([*args, "--baseline", "steady"]) == 0
    assert main(args) == 0
    assert [o.options for o in seen] == [{"baseline": "steady"}, {}]
    assert seen[0].fingerprint() != seen[1].fingerprint()
    assert "baseline" not in seen[1].fingerprint()  # not given: not part of the key
    assert main([*args, "--baseline", "magic"]) == 2
    assert "--baseline" in capsys.readouterr().err


def _archive(tmp_path: Path, toml: str) -> tuple[Path, Path]:
    archive = tmp_path / "archive"
    (archive / "truck").mkdir(parents=True)
    (archive / "logcal.toml").write_text(toml)
    log = archive / "truck" / "run.csv"
    log.write_text("t,psi\n0,0\n")
    return archive, log


def test_a_settings_file_names_the_baseline_by_key(tmp_path: Path) -> None:
    archive, log = _archive(tmp_path, 'baseline = "steady"\n')
    s = settings_for(archive, log)
    assert s.options == {"baseline": "steady"}
    opts = s.robot_options["tractor_trailer"]
    assert isinstance(opts, TractorTrailerOptions)
    assert opts.baseline is Baseline.STEADY
    (archive / "logcal.toml").write_text('baseline = "magic"\n')
    with pytest.raises(SettingsError) as err:
        settings_for(archive, log)
    assert "baseline" in str(err.value)
    assert "transient, steady" in str(err.value)


@pytest.mark.parametrize(
    ("given", "expected"), [({}, Baseline.STEADY), ({"baseline": "transient"}, Baseline.TRANSIENT)]
)
def test_the_command_line_wins_over_the_settings_file(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    given: dict[str, str],
    expected: Baseline,
) -> None:
    archive, log = _archive(tmp_path, 'baseline = "steady"\n')
    configs: list[Any] = []

    def fake_analyze_log(path: str, *, channel_map: Any, config: Any) -> None:
        configs.append(config)
        raise LogcalInputError("stop here")

    monkeypatch.setattr("logtools.analyze.analyze_log", fake_analyze_log)
    job = LogJob(
        rel="truck/run.csv",
        path=str(log),
        id="run",
        content_hash="x",
        settings=settings_for(archive, log),
    )
    outcome = analyse_job(job, AnalysisOptions(repeats=1, views=False, options=given))
    assert (outcome.status, outcome.error) == ("failed", "stop here")
    assert configs[0].options(TractorTrailerOptions).baseline is expected
