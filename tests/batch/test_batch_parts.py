"""The parts of a batch on small inputs: logcal.toml settings, ids, pooling, drift, serving."""

from __future__ import annotations

import math
import re
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from calib.pooling.drift import detect_drift
from calib.pooling.meta import pool_estimates
from logtools.batch.archive import find_logs, log_id
from logtools.batch.serve import rerun_binary, start_server
from logtools.batch.settings import SettingsError, settings_for


def test_settings_nearest_wins_and_bad_keys_are_named(tmp_path: Path) -> None:
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "logcal.toml").write_text('robot_id = "root"\nrobot = "tractor_trailer"\n')
    (tmp_path / "a" / "b" / "logcal.toml").write_text('robot_id = "deep"\n')
    log = tmp_path / "a" / "b" / "x.mcap"
    s = settings_for(tmp_path, log)
    assert (s.robot_id, s.robot) == ("deep", "tractor_trailer")
    assert settings_for(tmp_path, tmp_path / "a" / "y.mcap").robot_id == "root"
    (tmp_path / "a" / "logcal.toml").write_text('wheel = "x"\n')
    with pytest.raises(SettingsError, match=r"a/logcal\.toml: \[wheel\] is not a logcal\.toml key"):
        settings_for(tmp_path, log)
    (tmp_path / "a" / "logcal.toml").write_text('channel_map = "missing.toml"\n')
    with pytest.raises(SettingsError, match=r"missing\.toml"):
        settings_for(tmp_path, log)


def test_settings_take_every_robots_options_from_the_plugins(tmp_path: Path) -> None:
    from logtools.robots.manipulator.options import ManipulatorOptions
    from logtools.robots.tractor_trailer.options import TractorTrailerOptions

    (tmp_path / "arm").mkdir()
    (tmp_path / "arm" / "arm.urdf").write_text("<robot/>")
    (tmp_path / "logcal.toml").write_text("discovery_span_s = 60\ncutoff_hz = 8\n")
    (tmp_path / "arm" / "logcal.toml").write_text('urdf = "arm.urdf"\ncutoff_hz = 5.5\n')
    log = tmp_path / "arm" / "x.csv"
    s = settings_for(tmp_path, log)
    urdf = str((tmp_path / "arm" / "arm.urdf").resolve())
    assert s.options == {"cutoff_hz": 5.5, "discovery_span_s": 60.0, "urdf": urdf}
    assert s.robot_options == {
        "manipulator": ManipulatorOptions(urdf=urdf, cutoff_hz=5.5),
        "tractor_trailer": TractorTrailerOptions(discovery_span_s=60.0),
    }
    before = s.fingerprint
    (tmp_path / "arm" / "arm.urdf").write_text("<robot name='b'/>")  # the file's content counts
    assert settings_for(tmp_path, log).fingerprint != before
    toml = tmp_path / "arm" / "logcal.toml"
    toml.write_text("cutoff_hz = -1\n")  # checked by the option's declaration
    with pytest.raises(
        SettingsError, match=re.escape(f"{toml}: cutoff_hz = -1: expected a number > 0")
    ):
        settings_for(tmp_path, log)
    toml.write_text('urdf = "missing.urdf"\n')  # names a file: it must be one, inside
    with pytest.raises(SettingsError, match=r"\[urdf\] names 'missing\.urdf', which is not a"):
        settings_for(tmp_path, log)
    toml.write_text('urdf = "panda"\n')  # a model name: no file
    assert settings_for(tmp_path, log).options["urdf"] == "panda"
    toml.write_text("wheel_base = 2\n")
    with pytest.raises(
        SettingsError,
        match=r"expected one of robot, channel_map, robot_id, "
        r".*cutoff_hz",
    ):
        settings_for(tmp_path, log)


def test_default_robot_id_is_the_top_folder(tmp_path: Path) -> None:
    assert settings_for(tmp_path, tmp_path / "t1" / "d" / "x.mcap").robot_id == "t1"
    assert settings_for(tmp_path, tmp_path / "x.mcap").robot_id == "(archive root)"


def test_log_ids_are_safe_and_distinct() -> None:
    ids = {log_id(r) for r in ("a/b.mcap", "a_b.mcap", "<x>/'y'.mcap", "../../etc.csv")}
    assert len(ids) == 4
    assert all(
        set(i) <= set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-")
        for i in ids
    )


def test_archive_walk_skips_hidden_and_output_folders(tmp_path: Path) -> None:
    for name in ("a.mcap", "b.csv", ".hidden.mcap", "out/c.mcap", "notes.txt", "bag/x.db3"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"x")
    (tmp_path / "bag" / "metadata.yaml").write_text("x")
    (tmp_path / "bag" / "inner.mcap").write_bytes(b"y")
    jobs = find_logs(tmp_path, skip=(tmp_path / "out",))
    assert [j.rel for j in jobs] == ["a.mcap", "b.csv", "bag"]
    assert jobs[0].content_hash != jobs[2].content_hash


def test_archive_walk_takes_the_registered_formats(tmp_path: Path) -> None:
    from logtools.readers import formats
    from logtools.readers.format_reader import FormatReader

    (tmp_path / "a.xyz").write_bytes(b"x")
    (tmp_path / "b.tum").write_bytes(b"0 0 0 0 0 0 0 1\n")
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "s1_metadata.csv").write_text("type,x\n")  # a session's metadata
    (tmp_path / "s" / "s1_run-1.csv").write_text("1,2\n")
    assert [j.rel for j in find_logs(tmp_path)] == ["b.tum", "s/s1_run-1.csv"]
    saved = list(formats.formats())
    try:  # a format plugin's files are walked too
        formats.register_format(
            FormatReader("xyz", "XYZ log", (".xyz",), lambda p, h: True, lambda name, req: None)
        )  # type: ignore[arg-type,return-value]
        assert [j.rel for j in find_logs(tmp_path)] == ["a.xyz", "b.tum", "s/s1_run-1.csv"]
    finally:
        formats._REGISTRY[:] = saved


def test_inverse_variance_pool_by_hand() -> None:
    p = pool_estimates(
        "L1", "m", ["a", "b", "c"], [1.0, 1.2, None], [0.1, 0.2, None], [True, True, False]
    )
    w = np.array([100.0, 25.0])
    assert p.estimate.value == pytest.approx((100 * 1.0 + 25 * 1.2) / 125)
    assert p.estimate.std == pytest.approx(1 / math.sqrt(w.sum()))
    assert p.n_logs == 2
    assert p.left_out == ["c: not determined by this log"]
    assert p.q == pytest.approx(100 * (1.0 - 1.04) ** 2 + 25 * (1.2 - 1.04) ** 2)
    assert not p.heterogeneous
    none = pool_estimates("L1", "m", ["a"], [None], [None], [False])
    assert not none.estimate.identifiable
    assert math.isnan(none.estimate.value)


def test_drift_finds_a_large_step_and_its_place() -> None:
    logs = [f"l{i}" for i in range(8)]
    t = [i * 86_400 * 10**9 for i in range(8)]
    x = [1.0, 1.001, 0.999, 1.0, 1.2, 1.199, 1.201, 1.2]
    d = detect_drift(logs, t, x, [0.002] * 8, "m")
    assert d.change_point
    assert d.change_after == "l3"
    assert d.change_before == "l4"
    assert d.shift == pytest.approx(0.2, abs=1e-3)
    flat = detect_drift(logs, t, [1.0] * 8, [0.002] * 8, "m")
    assert not flat.change_point
    assert flat.p_change == 1.0
    assert detect_drift(logs[:3], t[:3], x[:3], [0.002] * 3).status == "too few logs"


def _get(url: str) -> tuple[int, dict[str, str], bytes]:
    class NoRedirect(urllib.request.HTTPRedirectHandler):
        def redirect_request(self, *args: object, **kw: object) -> None:
            return None

    opener = urllib.request.build_opener(NoRedirect)
    try:
        with opener.open(url, timeout=10) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as err:
        return err.code, dict(err.headers), err.read()


def _report(tmp_path: Path) -> Path:
    (tmp_path / "views").mkdir()
    (tmp_path / "index.html").write_text("<p>report</p>")
    (tmp_path / "views" / "x.rrd").write_bytes(b"RRF2....")
    return tmp_path


def test_serve_binds_loopback_and_refuses_paths_outside(tmp_path: Path) -> None:
    server = start_server(_report(tmp_path), port=0, viewer=False)
    try:
        assert server.httpd.server_address[0] == "127.0.0.1"
        assert _get(server.url + "index.html")[0] == 200
        assert _get(server.url + "rerun/open?rrd=views/x.rrd")[0] == 503  # no viewer
        assert _get(server.url + "rerun/open?rrd=../../etc/passwd")[0] == 404
    finally:
        server.close()


@pytest.mark.skipif(rerun_binary() is None, reason="rerun-sdk's rerun binary not found")
def test_serve_redirects_to_rerun_web_viewer(tmp_path: Path) -> None:
    server = start_server(_report(tmp_path), port=0, viewer=True)
    try:
        assert server.viewer_url is not None
        assert server.viewer_url.startswith("http://127.0.0.1:")
        status, headers, _ = _get(server.url + "rerun/open?rrd=views/x.rrd")
        assert status == 302
        assert headers["Location"].startswith(server.viewer_url + "?url=http%3A%2F%2F127.0.0.1")
        status, headers, body = _get(server.url + "views/x.rrd")
        assert status == 200
        assert body == b"RRF2...."
        assert headers["Access-Control-Allow-Origin"] == server.viewer_url.rstrip("/")
        assert _get(server.viewer_url)[0] == 200  # the viewer page rerun-sdk ships
    finally:
        server.close()
    assert server.viewer is not None
    assert server.viewer.poll() is not None


def test_cli_batch_names_a_missing_archive(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from logtools.cli.main import main

    code = main(["batch", str(tmp_path / "nowhere"), "--out", str(tmp_path / "out")])
    assert code == 2
    assert "nowhere: not a folder" in capsys.readouterr().err


@pytest.mark.slow
def test_discovered_effects_become_table_rows(tmp_path: Path) -> None:
    import dataclasses

    import polars as pl
    from batch_archive import FAST, T0_NS

    from calib.tractor_trailer.sim.presets import preset
    from calib.tractor_trailer.sim.tractor_trailer import Effects, simulate_tractor_trailer
    from logtools.batch.runner import read_records, run_batch
    from logtools.writers.tractor_trailer import run_metadata, write_run

    cfg = preset("harmonic", duration_s=63.0, rate_hz=20.0, effects=Effects(actuator_delay_s=0.4))
    run = simulate_tractor_trailer(dataclasses.replace(cfg, start_time_ns=T0_NS), seed=3)
    (tmp_path / "a").mkdir()
    write_run(tmp_path / "a" / "delay.mcap", run, metadata=run_metadata(run))
    out = tmp_path / "out"
    run_batch(tmp_path / "a", out, options=dataclasses.replace(FAST, discovery=True))
    (record,) = read_records(out)
    effects = record["result"]["discovery"]["effects"]
    assert effects, "discovery found nothing: the test would check nothing"
    rows = pl.read_parquet(out / "fleet.parquet").filter(pl.col("kind") == "effect")
    assert rows["parameter"].to_list() == [
        f"{e['key']}: {p}" for e in effects for p in e["parameters"]
    ]
    assert rows["estimator"].unique().to_list() == ["discovery"]
    index = (out / "index.html").read_text()
    assert f"Effects found ({len(effects)})" in index
