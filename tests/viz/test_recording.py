"""The .rrd read back (rerun.chunk.RrdReader): entity paths, row counts and values."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import polars as pl
import pytest
from rrd_read import read_rrd
from viz_cases import views_for

from calib.results import PM_MEANING
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.views_data import transient_prediction
from viz.style import COLORS
from viz.tractor_trailer.methods import forest_rows
from viz.tractor_trailer.recording import write_recording

POS = "Points2D:positions"
STRIPS = "LineStrips2D:strips"
SCALARS = "Scalars:scalars"


@pytest.fixture(scope="module")
def recorded(case, tmp_path_factory):
    path = tmp_path_factory.mktemp("rrd") / "case.rrd"
    views = views_for(case.frame, case.result, "PMLS/PM1")
    write_recording(path, case.frame, case.result, views, method_for_psi="PMLS/PM1")
    ents, n_blueprints = read_rrd(path)
    return ents, n_blueprints


def test_entity_paths_and_blueprint(recorded):
    ents, n_blueprints = recorded
    assert n_blueprints == 1
    expected = {
        "/summary",
        "/segments/type",
        "/segments/log",
        "/world/paths/C1",
        "/world/paths/P",
        "/world/paths/C2",
        "/world/robot",
        "/world/icr",
        "/world/labels",
        "/world/follow",
        "/signals/kappa/command",
        "/signals/kappa/measured",
        "/signals/psi/measured",
        "/signals/psi/predicted_estimate",
        "/signals/psi/predicted_method",
        "/signals/residuals/psi_before",
        "/signals/residuals/psi_after",
        "/methods/table",
    }
    for seg in ("all", "harmonic", "curve"):
        expected |= {
            f"/methods/{seg}/{k}"
            for k in ("names", "bars", "bars_value", "lines", "ticks", "titles")
        }
    assert expected <= set(ents)


def test_row_counts_and_timeline(recorded, case):
    """Every series is on one timeline, in ns from the log's start (as the text and the PNG);
    the absolute start is stated once, in the summary."""
    ents, _ = recorded
    t_abs = case.frame["t_ns"].to_numpy()
    t_ns = t_abs - t_abs[0]
    n = case.frame.height
    for path, comp in (
        ("/world/robot", POS),
        ("/world/robot", STRIPS),
        ("/world/icr", POS),
        ("/world/icr", STRIPS),
        ("/signals/psi/measured", SCALARS),
    ):
        t, vals = ents[path].rows(comp)
        assert t.size == n, path
        assert len(vals) == n, path
        np.testing.assert_array_equal(t, t_ns)
    assert len(ents["/segments/type"].times_ns) == len(case.result.segments)
    res = case.result.discovery.residuals
    t, vals = ents["/signals/residuals/psi_before"].rows(SCALARS)
    np.testing.assert_array_equal(t, np.asarray(res["t_ns"]) - t_abs[0])
    np.testing.assert_allclose(np.concatenate(vals), res["psi_before"])
    summary = ents["/summary"].static["TextDocument:text"][0]
    assert "seconds from the log's start, started 2025-06-15 15:06:40.000 UTC" in summary


def test_segment_labels_at_segment_starts(recorded, case):
    ents, _ = recorded
    segs = case.result.segments
    starts = [round(s.start_s * 1e9) for s in segs]  # from the log's start
    t, text = ents["/segments/log"].rows("TextLog:text")
    np.testing.assert_array_equal(t, starts)
    for s, line in zip(segs, text, strict=True):
        assert line[0].startswith(f"{s.command_type} segment {s.start_s:.1f}")
    t, state = ents["/segments/type"].rows("StateChange:state")
    np.testing.assert_array_equal(t, starts)
    assert [x[0] for x in state] == [str(s.command_type) for s in segs]


def test_logged_o_is_the_closed_form_centre(recorded, case):
    """O = C1 + (1/kappa) (-sin yaw, cos yaw) at sampled times; empty where kappa ~ 0."""
    ents, _ = recorded
    f = case.frame
    _, rows = ents["/world/icr"].rows(POS)  # per row [O, Q] or []
    kappa, yaw = f["kappa"].to_numpy(), f["yaw"].to_numpy()
    x, y = f["x"].to_numpy(), f["y"].to_numpy()
    rng = np.random.default_rng(0)
    turning = np.flatnonzero(np.abs(kappa) >= 1e-3)
    straight = np.flatnonzero(np.abs(kappa) < 1e-3)
    assert turning.size > 100
    assert straight.size > 100  # the constant-zero segment
    for i in rng.choice(turning, 50, replace=False):
        expected = [x[i] - np.sin(yaw[i]) / kappa[i], y[i] + np.cos(yaw[i]) / kappa[i]]
        np.testing.assert_allclose(rows[i][0], expected, rtol=1e-6, atol=1e-4)  # float32
    for i in rng.choice(straight, 20, replace=False):
        assert rows[i] == []


def test_robot_links_from_psi_and_calibrated_lengths(recorded, case):
    ents, _ = recorded
    est = case.result.estimate.parameters
    L1, L2 = est["L1"].value, est["L2"].value
    f = case.frame
    _, strips = ents["/world/robot"].rows(STRIPS)
    _, points = ents["/world/robot"].rows(POS)
    for i in (0, f.height // 3, f.height - 1):
        c1, p, c2 = np.asarray(strips[i][0])
        np.testing.assert_array_equal(points[i], strips[i][0])
        assert np.linalg.norm(c1 - p) == pytest.approx(L1, rel=1e-5)
        assert np.linalg.norm(p - c2) == pytest.approx(L2, rel=1e-5)
        np.testing.assert_allclose(c1, [f["x"][i], f["y"][i]], rtol=1e-6, atol=1e-5)
        heading2 = np.arctan2(*(p - c2)[::-1])
        assert np.angle(np.exp(1j * (heading2 - f["yaw"][i] + f["psi"][i]))) == pytest.approx(
            0.0, abs=1e-4
        )


def test_psi_predictions(recorded, case):
    ents, _ = recorded
    kappa = case.frame["kappa"].to_numpy()
    est = case.result.estimate.parameters
    _, vals = ents["/signals/psi/predicted_estimate"].rows(SCALARS)
    want = steady_state_psi(kappa, est["L1"].value, est["L2"].value)
    ok = np.isfinite(want)
    np.testing.assert_allclose(np.concatenate(vals), want[ok])
    pm = next(m for m in case.result.methods if m.name == "PMLS/PM1" and m.segment == "all")
    _, vals = ents["/signals/psi/predicted_method"].rows(SCALARS)
    want = steady_state_psi(kappa, pm.L1, pm.L2)
    np.testing.assert_allclose(np.concatenate(vals), want[np.isfinite(want)])


def test_error_bars_name_every_row_and_keep_the_order_of_values(recorded, case):
    ents, _ = recorded
    table = ents["/methods/table"].static["TextDocument:text"][0]
    assert PM_MEANING in table
    for seg in ("all", "harmonic", "curve"):
        rows = forest_rows([m for m in case.result.methods if m.segment == seg])
        det = [r for r in rows if r.apart is None]
        base = f"/methods/{seg}"
        assert ents[f"{base}/names"].static["Points2D:labels"] == [r.label for r in det]
        bars = ents[f"{base}/bars"].static[STRIPS]
        assert len(bars) == 4 * len(det)  # L1, L1 zoomed, L2, L2 zoomed
        centres = [np.mean([pt[0] for pt in b]) for b in bars[: len(det)]]  # L1, full range
        assert np.argsort(centres).tolist() == np.argsort([r.L1 for r in det]).tolist()
        # truth and recommended lines in all four panels (both lie inside each range)
        assert len(ents[f"{base}/lines"].static[STRIPS]) == 8
        for r in rows:
            assert r.names[0] in table


def test_static_colours(recorded):
    ents, _ = recorded

    def packed(name):
        r, g, b = COLORS[name]
        return (r << 24) | (g << 16) | (b << 8) | 0xFF

    assert ents["/world/icr"].static["Points2D:colors"] == [packed("O"), packed("Q")]
    strips = ents["/world/icr"].static["LineStrips2D:colors"]
    assert strips == [packed(n) for n in ("triangle_OQC2", "triangle_QC1P", "radius")]
    assert "Points2D:labels" not in ents["/world/robot"].static  # labels: world/labels


def test_partial_frame_and_unknown_method(case, tmp_path):
    """A log with only command and joint angle: no world, the series that exist."""
    small = case.frame.select("t_ns", "kappa_cmd", "psi")
    views = views_for(small, case.result)
    path = write_recording(tmp_path / "small.rrd", small, case.result, views)
    ents, _ = read_rrd(path)
    assert not any(e.startswith("/world/") for e in ents)
    assert {"/signals/kappa/command", "/signals/psi/measured"} <= set(ents)
    with pytest.raises(KeyError, match="EMLS/EM1"):
        write_recording(tmp_path / "x.rrd", small, case.result, method_for_psi="nope")


def test_nan_samples_are_left_out(case, tmp_path):
    f = case.frame.with_columns(
        pl.when(pl.int_range(pl.len()) % 7 == 0).then(None).otherwise(pl.col("psi")).alias("psi")
    )
    path = write_recording(tmp_path / "nan.rrd", f, case.result, views_for(f, case.result))
    ents, _ = read_rrd(path)
    t, _ = ents["/signals/psi/measured"].rows(SCALARS)
    assert t.size == f["psi"].drop_nulls().len()
    _, links = ents["/world/robot"].rows(STRIPS)
    assert links[0] == []
    assert len(links[1]) == 1


def test_icr_triangles_radius_and_label(recorded, case):
    """Per row: triangle O Q C2, triangle Q C1 P, radius O C1 (|O C1| = 1/|kappa|); O's label
    gives R = 1/kappa (m)."""
    ents, _ = recorded
    f = case.frame
    kappa = f["kappa"].to_numpy()
    _, strips = ents["/world/icr"].rows(STRIPS)
    _, points = ents["/world/icr"].rows(POS)
    _, labels = ents["/world/labels"].rows("Points2D:labels")
    _, robot = ents["/world/robot"].rows(POS)
    i = int(np.argmax(np.abs(kappa)))
    o, q = np.asarray(points[i])
    c1, p, c2 = np.asarray(robot[i])
    tri1, tri2, radius = (np.asarray(s) for s in strips[i])
    np.testing.assert_allclose(tri1, [o, q, c2, o], rtol=1e-6)
    np.testing.assert_allclose(tri2, [q, c1, p, q], rtol=1e-6)
    np.testing.assert_allclose(radius, [o, c1], rtol=1e-6)
    assert np.linalg.norm(o - c1) == pytest.approx(1 / abs(kappa[i]), rel=1e-5)
    assert labels[i] == ["C1", "P", "C2", f"O: R = 1/κ = {1 / kappa[i]:.2f} m", "Q"]
    j = int(np.argmin(np.abs(kappa)))
    assert strips[j] == []
    assert points[j] == []
    assert labels[j] == ["C1", "P", "C2"]


def test_recommended_transient_prediction_is_drawn_as_that_model(case, tmp_path):
    """The transient fit's own prediction goes on its stamps, named with its model and the
    lengths it was simulated with (not the steady-state relation)."""
    t_ns = case.frame["t_ns"].to_numpy()
    t0 = int(t_ns[0])
    t_s = (t_ns[::5] - t0) / 1e9
    fit = SimpleNamespace(
        t_s_=t_s,
        psi_fit_=np.sin(t_s),
        residual_=0.01 * np.cos(t_s),
        psi_offset_=0.0,
        L1_=1.26,
        L2_=2.47,
        bias_correction_=np.array([0.01, -0.01]),
    )
    pred = transient_prediction(fit, t0)
    np.testing.assert_array_equal(pred["psi_model_t_ns"], t_ns[::5])
    np.testing.assert_allclose(pred["psi_model_params"], [1.25, 2.48, 0.0])
    views = views_for(case.frame, case.result) | pred
    path = write_recording(tmp_path / "m.rrd", case.frame, case.result, views)
    ents, _ = read_rrd(path)
    _t, vals = ents["/signals/psi/predicted_model"].rows(SCALARS)
    np.testing.assert_allclose(np.concatenate(vals), np.sin(t_s))
    name = ents["/signals/psi/predicted_model"].static["SeriesLines:names"][0]
    assert "transient" in name
    assert "L1 = 1.250 m, L2 = 2.480 m" in name
    est = case.result.estimate.parameters  # and the lengths the report gives, as it gives them
    assert f"L1 = {est['L1'].value:.3f} m, L2 = {est['L2'].value:.3f} m)" in name
    assert case.result.estimate.method in name
    steady = ents["/signals/psi/predicted_estimate"].static["SeriesLines:names"][0]
    assert steady.startswith("ψ steady-state relation")


def test_kappa_command_shows_around_the_measured_line(recorded):
    """The command is drawn wider than the measured curvature over it (it was hidden under it)."""
    ents, _ = recorded
    cmd = ents["/signals/kappa/command"].static["SeriesLines:widths"][0]
    meas = ents["/signals/kappa/measured"].static["SeriesLines:widths"][0]
    assert cmd >= 3 * meas
