"""End-to-end checks of `logcal analyze` against the simulated truth of the bundled sample logs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from logtools.cli.main import main
from logtools.readers import read_log

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_logs"
REALWORLD = ROOT.parent / "shared" / "realworld_mcap"
PATENT_METHODS = 36


def _truth(path: Path) -> dict[str, float]:
    meta = read_log(path).metadata["logcal"]
    return {"L1": float(meta["L1"]), "L2": float(meta["L2"])}


@pytest.fixture(scope="module")
def mixed_json(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("analyze") / "mixed.json"
    code = subprocess.run(
        [
            sys.executable,
            "-m",
            "logtools.cli.main",
            "analyze",
            str(SAMPLES / "tt_mixed.mcap"),
            "--json",
            "--repeats",
            "3",
        ],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
    )
    assert code.returncode == 0, code.stderr
    out.write_text(code.stdout)
    return json.loads(code.stdout)


def test_json_document_has_the_promised_fields(mixed_json: dict) -> None:
    assert mixed_json["robot"] == "tractor_trailer"
    for seg in mixed_json["segments"]:
        assert {"start_s", "end_s", "command_type"} <= seg.keys()
    for m in mixed_json["methods"]:
        assert {"name", "segment", "L1", "L2", "L1_std", "L2_std", "condition_number"} <= m.keys()
    est = mixed_json["estimate"]
    for p in ("L1", "L2"):
        assert {"value", "ci95", "identifiable"} <= est[p].keys()
    assert {"value", "ci95"} <= est["sum_L1_L2"].keys()
    disc = mixed_json["discovery"]
    assert {"effects", "baseline", "verdict_before", "verdict_after", "details"} <= disc.keys()
    command = disc["details"]["command_driven"]
    assert {"regions", "effects", "baseline"} <= command.keys()
    assert command["windows"] is None  # a short log is looked at whole


def test_every_patent_method_is_reported_for_the_whole_log(mixed_json: dict) -> None:
    whole = [m for m in mixed_json["methods"] if m["segment"] == "all"]
    patent = [m for m in whole if m["family"] in ("EMLS", "PMLS", "CLS")]
    assert len(patent) == PATENT_METHODS
    assert {m["family"] for m in whole} >= {"EIV", "TRANSIENT"}


def test_segments_are_the_simulated_command_types(mixed_json: dict) -> None:
    kinds = [s["command_type"] for s in mixed_json["segments"]]
    # tt_mixed plays harmonic, curve, linear, constant, step (logtools.sample_logs).
    assert kinds == ["harmonic", "curve", "linear", "constant", "step"]
    per_type = {m["segment"] for m in mixed_json["methods"]}
    assert per_type >= {"all", "harmonic", "curve", "linear"}


def test_recommended_estimate_matches_the_simulated_truth(mixed_json: dict) -> None:
    truth = _truth(SAMPLES / "tt_mixed.mcap")
    est = mixed_json["estimate"]
    lo, hi = est["sum_L1_L2"]["ci95"]
    assert lo <= truth["L1"] + truth["L2"] <= hi
    # The split: within 2 % of the truth. (Its 95 % interval on this one 20 Hz log is narrower
    # than the error; coverage over many logs is measured by bench/coverage_study.py.)
    for p in ("L1", "L2"):
        assert est[p]["identifiable"] is True
        assert est[p]["value"] == pytest.approx(truth[p], rel=0.02)


def test_default_baseline_is_transient_and_names_nothing_on_a_clean_run(mixed_json: dict) -> None:
    command = mixed_json["discovery"]["details"]["command_driven"]
    assert command["baseline"] == "transient"
    assert command["effects"] == []
    assert mixed_json["discovery"]["named"] == []


@pytest.mark.slow
def test_steady_baseline_names_the_hitch_transient(capsys: pytest.CaptureFixture[str]) -> None:
    """The patent's steady-state view leaves out the trailer's transient: discovery names it."""
    code = main(
        [
            "analyze",
            str(SAMPLES / "tt_mixed.mcap"),
            "--json",
            "--repeats",
            "1",
            "--baseline",
            "steady",
        ]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert "hitch_transient" in [e["id"] for e in doc["discovery"]["effects"]]


def test_discovery_span_limits_what_discovery_looks_at(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(
        [
            "analyze",
            str(SAMPLES / "tt_mixed.mcap"),
            "--json",
            "--repeats",
            "1",
            "--discovery-span",
            "100",
        ]
    )
    assert code == 0
    disc = json.loads(capsys.readouterr().out)["discovery"]
    win = disc["details"]["command_driven"]["windows"]
    assert win["used_s"] == pytest.approx(100.0)
    assert win["total_s"] > 100.0
    assert win["windows_s"][0][0] == 0.0
    assert win["windows_s"][-1][1] == pytest.approx(win["total_s"])
    code = main(
        ["analyze", str(SAMPLES / "tt_mixed.mcap"), "--repeats", "1", "--discovery-span", "100"]
    )
    assert "Discovery looked at 100 s of the" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.parametrize("name", ["tt_mixed_ros2.mcap", "tt_mixed.csv"])
def test_other_encodings_give_the_same_estimate(
    name: str, capsys: pytest.CaptureFixture[str], mixed_json: dict
) -> None:
    code = main(["analyze", str(SAMPLES / name), "--json", "--repeats", "1", "--no-discovery"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    for p in ("L1", "L2"):
        ref = mixed_json["estimate"][p]["value"]
        assert doc["estimate"][p]["value"] == pytest.approx(ref, abs=0.02)


def test_terminal_report_warns_about_the_cls_split(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(
        [
            "analyze",
            str(SAMPLES / "tt_harmonic_clean.mcap"),
            "--repeats",
            "1",
            "--no-discovery",
            "--methods",
        ]
    )  # the method tables come with --methods
    out = capsys.readouterr().out
    assert code == 0
    assert "Recommended estimate" in out
    assert "Taylor expansion" in out


@pytest.mark.slow
def test_rrd_and_png_are_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rrd = tmp_path / "out.rrd"
    code = main(
        [
            "analyze",
            str(SAMPLES / "tt_harmonic_clean.mcap"),
            "--repeats",
            "1",
            "--no-discovery",
            "--rrd",
            str(rrd),
            "--json",
        ]
    )
    assert code == 0
    assert rrd.stat().st_size > 10_000
    assert rrd.with_suffix(".png").stat().st_size > 10_000


@pytest.mark.skipif(not REALWORLD.is_dir(), reason="shared/realworld_mcap not beside the repo")
@pytest.mark.parametrize("name", ["talker.mcap", "wbag_0.mcap", "only_topics.mcap"])
def test_logs_without_drive_signals_say_what_is_missing(
    name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["analyze", str(REALWORLD / name)])
    err = capsys.readouterr().err
    assert code == 2
    assert name in err
    assert "psi" in err or "drive signals" in err
    assert "Traceback" not in err


def test_bad_baseline_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["analyze", str(SAMPLES / "tt_mixed.csv"), "--baseline", "magic"])
    assert code == 2
    assert "--baseline" in capsys.readouterr().err


def test_a_missing_compiled_integrator_is_said_once(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import calib.tractor_trailer.models.hitch_rk4 as rk4

    monkeypatch.setattr(rk4, "_library", lambda: None)  # as in a source tree never built
    code = main(
        [
            "analyze",
            str(SAMPLES / "tt_harmonic_clean.mcap"),
            "--json",
            "--repeats",
            "1",
            "--no-discovery",
        ]
    )
    assert code == 0
    # the tractor pipeline notes it in its result (the shared CLI names no robot's extension)
    notes = [
        w for w in json.loads(capsys.readouterr().out)["warnings"] if "compiled integrator" in w
    ]
    assert len(notes) == 1
    assert "about 5x slower" in notes[0]
