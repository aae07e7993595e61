"""Windowed analysis of a long log (logtools/windows.py): each window read on its own (a time
range read of an MCAP file touches only its chunks), analysed, and pooled with honest
uncertainty; a parameter that changes between windows is flagged; ``--window`` bad values exit
2. The memory bound itself is measured by bench/bench_long_log.py (peak RSS of a 24-hour log
against a 1-hour one in the same run)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from calib.tractor_trailer.sim.presets import preset
from calib.tractor_trailer.sim.tractor_trailer import simulate_tractor_trailer
from logtools.analyze import AnalysisConfig, analyze_log
from logtools.cli.main import main
from logtools.readers import log_extent, read_log
from logtools.windows import plan_windows
from logtools.writers.mcap_writer import JsonEncoder, write_frames_mcap
from logtools.writers.tractor_trailer import JSON_BINDINGS, run_frames, run_metadata

FAST = AnalysisConfig(repeats=1, discovery=False)


def _pieces_log(
    path: Path, l2s: list[float], piece_s: float, chunk_size: int | None = None
) -> Path:
    """A 100 Hz tractor-trailer log of consecutive simulated pieces of ``piece_s`` each, the
    trailer's L2 of each piece from ``l2s`` (the pose carried on from piece to piece)."""
    pieces = []
    x0 = y0 = yaw0 = 0.0
    meta = None
    for k, l2 in enumerate(l2s):
        cfg = preset("mixed", rate_hz=100.0, duration_s=piece_s, L2=l2)
        cfg = replace(cfg, start_time_ns=cfg.start_time_ns + round(k * piece_s * 1e9))
        run = simulate_tractor_trailer(cfg, seed=k)
        end = cfg.start_time_ns + round(piece_s * 1e9)
        fr = {g: f.filter(pl.col("t_ns") < end) for g, f in run_frames(run).items()}
        c, s = math.cos(yaw0), math.sin(yaw0)
        p = fr["pose"]
        px, py, yaw = p["x"].to_numpy(), p["y"].to_numpy(), p["yaw"].to_numpy() + yaw0
        fr["pose"] = p.with_columns(
            pl.Series("x", x0 + c * px - s * py),
            pl.Series("y", y0 + s * px + c * py),
            pl.Series("yaw", yaw),
            pl.Series("qz", np.sin(yaw / 2)),
            pl.Series("qw", np.cos(yaw / 2)),
        )
        last = run.truth.row(-1, named=True)
        x0, y0, yaw0 = (
            x0 + c * last["x"] - s * last["y"],
            y0 + s * last["x"] + c * last["y"],
            yaw0 + last["yaw"],
        )
        pieces.append(fr)
        meta = meta or run_metadata(run)
    frames = {g: pl.concat([f[g] for f in pieces]) for g in pieces[0]}
    enc = JsonEncoder()
    if chunk_size is not None:  # small chunks: a time range then spans few of many
        from mcap.writer import Writer

        def small_chunks(fh, compression, chunked):  # type: ignore[no-untyped-def]
            enc._writer = Writer(fh, compression=compression, chunk_size=chunk_size)
            enc._writer.start(profile="", library="logcal")

        enc.start = small_chunks  # type: ignore[method-assign]
    write_frames_mcap(path, frames, JSON_BINDINGS, enc, metadata=meta)
    return path


@pytest.fixture(scope="module")
def steady_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _pieces_log(tmp_path_factory.mktemp("win") / "steady.mcap", [2.48] * 4, 60.0)


@pytest.fixture(scope="module")
def windowed(steady_log: Path) -> tuple[object, object]:
    _, whole = analyze_log(steady_log, config=replace(FAST, window_s=0))
    _, win = analyze_log(steady_log, config=replace(FAST, window_s=60))
    return whole, win


def test_windows_pool_to_an_interval_that_overlaps_the_whole_log(windowed) -> None:  # type: ignore[no-untyped-def]
    whole, win = windowed
    assert whole.estimate is not None
    assert win.estimate is not None
    assert "windows" not in whole.source
    assert win.source["windows"]["count"] == 4
    assert win.source["windows"]["analysed"] == 4
    assert len(win.runs) == 4
    assert [r.source["window"]["index"] for r in win.runs] == [1, 2, 3, 4]
    assert "analysed in 4 windows of 60 s" in win.warnings
    for name in ("L1", "L2"):
        a, b = whole.estimate.parameters[name], win.estimate.parameters[name]
        assert b.identifiable, b.note
        assert max(a.ci95[0], b.ci95[0]) <= min(a.ci95[1], b.ci95[1]), (name, a, b)
    assert win.adequacy is not None
    assert win.adequacy.explains
    assert not win.adequacy.changes
    assert all(r.artifacts == {} for r in win.runs)  # no window's arrays kept


def test_the_json_says_how_the_log_was_windowed(
    steady_log: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(
        ["analyze", str(steady_log), "--json", "--window", "60", "--repeats", "1", "--no-discovery"]
    )
    assert rc in (0, None)
    doc = json.loads(capsys.readouterr().out)
    w = doc["source"]["windows"]
    assert (w["count"], w["window_s"], w["automatic"]) == (4, 60.0, False)
    assert [round(a) for a, _ in w["spans_s"]] == [0, 60, 120, 180]
    assert len(doc["runs"]) == 4
    assert doc["estimate"]["method"].endswith("pooled over 4 windows")


def test_a_short_log_is_analysed_whole_by_default(steady_log: Path) -> None:
    assert plan_windows(steady_log, None) is None
    assert plan_windows(steady_log, 0) is None
    assert plan_windows(steady_log, 1000.0) is None  # one window: the whole log


def test_automatic_windows_when_the_log_is_long_for_its_rate(
    steady_log: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import logtools.windows as windows

    monkeypatch.setattr(windows, "AUTO_ROWS", 10_000)  # 100 s at 100 Hz
    monkeypatch.setattr(windows, "WINDOW_ROWS", 8_000)
    monkeypatch.setattr(windows, "MIN_AUTO_WINDOW_S", 0.0)
    plan = plan_windows(steady_log, None)
    assert plan is not None
    assert plan.automatic
    assert plan.window_s == 80.0  # 8000 samples at the fastest topic's 100 Hz
    assert len(plan.spans_s) == 3  # 0-80, 80-160, 160-240
    assert "automatic" in plan.describe()


def test_a_short_remainder_joins_the_last_window(steady_log: Path) -> None:
    plan = plan_windows(steady_log, 70.0)  # 240 s: 0-70, 70-140, 140-240 (30 s left over)
    assert plan is not None
    assert [round(a) for a, _ in plan.spans_s] == [0, 70, 140]
    plan = plan_windows(steady_log, 90.0, start_s=10.0, end_s=200.0)  # 190 s: 10-100, 100-200
    assert plan is not None
    assert not plan.whole
    assert [(round(a), round(b)) for a, b in plan.spans_s] == [(10, 100), (100, 200)]


def test_a_parameter_that_changes_between_windows_is_flagged(tmp_path: Path) -> None:
    path = _pieces_log(tmp_path / "changed.mcap", [2.48, 2.48, 3.2, 3.2], 60.0)
    _, res = analyze_log(path, config=replace(FAST, window_s=60))
    l2 = res.estimate.parameters["L2"]
    pooling = res.source["windows"]["pooling"]["L2"]
    assert pooling["heterogeneous"]
    assert l2.ci95[0] < 2.5
    assert l2.ci95[1] > 3.1
    assert not l2.identifiable  # one L2 does not hold over the log
    # under the misfit the pooled interval does not narrow below the windows' own spread
    values = [r.estimate.parameters["L2"].value for r in res.runs if r.estimate is not None]
    assert len(values) == 4
    assert l2.std >= float(np.std(values, ddof=1))
    assert res.adequacy is not None
    assert not res.adequacy.explains
    (change,) = res.adequacy.changes
    assert change.t_s == pytest.approx(120.0, abs=1.0)
    assert change.after["L2"] == pytest.approx(3.2, rel=0.01)
    assert any("L2 differs between the windows" in w for w in res.warnings)


def test_a_time_range_read_touches_only_its_chunks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import logtools.readers.builtin_formats as builtin
    import logtools.readers.mcap_reader as reader

    path = _pieces_log(tmp_path / "chunked.mcap", [2.48], 120.0, chunk_size=64 * 1024)
    monkeypatch.setattr(builtin, "_BATCHED_MIN_BYTES", 0)
    monkeypatch.setattr(reader, "BATCH_BYTES", 128 * 1024)
    opened: list[tuple[int, int]] = []
    scan = reader.scan_chunks

    def spy(buf, summary, chunks):  # type: ignore[no-untyped-def]
        opened.extend((c.message_start_time, c.message_end_time) for c in chunks)
        return scan(buf, summary, chunks)

    monkeypatch.setattr(reader, "scan_chunks", spy)
    whole = read_log(path)
    n_chunks = len(opened)
    ext = log_extent(path)
    assert ext is not None
    assert n_chunks > 10
    assert (ext.first_ns, ext.last_ns) == (
        min(i.first_ns for i in whole.info.values()),
        max(i.last_ns for i in whole.info.values()),
    )
    assert ext.messages == {t: i.message_count for t, i in whole.info.items()}
    t0, t1 = ext.first_ns + 40 * 10**9, ext.first_ns + 50 * 10**9
    opened.clear()
    part = read_log(path, span_ns=(t0, t1))
    assert opened
    assert len(opened) < n_chunks / 4
    assert all(e >= t0 and s <= t1 for s, e in opened)  # only chunks that meet the span
    for topic, frame in whole.topics.items():
        want = frame.filter(pl.col("t_ns").is_between(t0, t1))
        assert part.topics[topic].equals(want), topic
        assert part.info[topic].message_count == want.height
    assert not [p for p in part.problems if "lost" in str(p)]


def test_windows_of_a_log_without_an_index_read_it_to_learn_its_span(tmp_path: Path) -> None:
    from logtools.writers.tractor_trailer import write_run

    cfg = preset("mixed", rate_hz=20.0, duration_s=120.0)
    path = tmp_path / "run.csv"
    write_run(path, simulate_tractor_trailer(cfg, seed=1), encoding="csv")
    assert log_extent(path) is None
    assert plan_windows(path, None) is None  # automatic windows need an index
    plan = plan_windows(path, 60.0)
    assert plan is not None
    assert len(plan.spans_s) == 2


@pytest.mark.parametrize("value", ["-1", "nan", "inf", "-inf", "abc"])
def test_bad_window_exits_2(
    steady_log: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    assert main(["analyze", str(steady_log), "--window", value]) == 2
    err = capsys.readouterr().err
    assert "--window" in err
    assert "Traceback" not in err


def test_window_with_views_exits_2(
    steady_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rrd = tmp_path / "out.rrd"
    assert main(["analyze", str(steady_log), "--window", "60", "--rrd", str(rrd)]) == 2
    err = capsys.readouterr().err
    assert "--window 60" in err
    assert "--rrd" in err
    assert not rrd.exists()


def test_runs_analysed_by_windows_are_pooled_by_their_estimates(steady_log: Path) -> None:
    from logtools.analyze import analyze_logs

    _, res = analyze_logs([steady_log, steady_log], config=replace(FAST, window_s=120))
    assert [r.source["windows"]["count"] for r in res.runs] == [2, 2]
    assert res.estimate is not None
    assert res.estimate.method.endswith("pooled over 2 runs")
    assert res.source["runs_pooled"] == 2
    assert any("pooled by their estimates" in w for w in res.warnings)


def _arrays_reachable(obj: object) -> list[str]:
    """Paths to numpy arrays and polars frames reachable from ``obj`` through containers,
    dataclasses and instance attributes."""
    import dataclasses
    import enum

    seen: set[int] = set()
    stack: list[tuple[object, str]] = [(obj, "result")]
    found: list[str] = []
    while stack:
        o, path = stack.pop()
        if id(o) in seen or o is None or isinstance(o, (str, bytes, int, float, enum.Enum)):
            continue
        seen.add(id(o))
        if isinstance(o, (np.ndarray, pl.DataFrame, pl.Series)):
            found.append(path)
        elif isinstance(o, dict):
            stack += [(v, f"{path}.{k}") for k, v in o.items()]
        elif isinstance(o, (list, tuple, set, frozenset)):
            stack += [(v, f"{path}[{i}]") for i, v in enumerate(o)]
        elif dataclasses.is_dataclass(o):
            stack += [(getattr(o, f.name), f"{path}.{f.name}") for f in dataclasses.fields(o)]
        elif hasattr(o, "__dict__"):
            stack += [(v, f"{path}.{k}") for k, v in vars(o).items()]
    return found


def test_a_window_keeps_no_per_sample_arrays(steady_log: Path) -> None:
    """With discovery on, a window's analysis holds its fitter's context and corrected signals
    (arrays the length of the window): the kept result holds none of them, and its JSON is
    that of the analysis."""
    import logtools.analyze as analyze

    kept: list[tuple[object, object]] = []
    real = analyze.analyze_loaded

    def spy(loaded, **kw):  # type: ignore[no-untyped-def]
        res = real(loaded, **kw)
        kept.append((res, res.to_dict()))
        return res

    analyze.analyze_loaded = spy  # type: ignore[assignment]
    try:
        _, res = analyze_log(steady_log, config=AnalysisConfig(repeats=1, window_s=120))
    finally:
        analyze.analyze_loaded = real  # type: ignore[assignment]
    assert len(res.runs) == 2
    assert any(_arrays_reachable(full) for full, _ in kept)  # what there was to drop
    for window, (_, doc) in zip(res.runs, kept, strict=True):
        assert _arrays_reachable(window) == []
        own = window.to_dict()
        assert own.pop("source")["window"]["index"] in (1, 2)
        doc.pop("source")
        assert own == doc


# --- pooling the windows by their covariances (calib.pooling through pool_windows) ---------


def _window(
    k: int, l1: float, l2: float, cov: list[list[float]] | None, sum_determined: bool = True
) -> object:
    """A window's result as pool_windows receives it: a tractor estimate (L1, L2, their
    covariance, the sum as the estimator would give it)."""
    from calib.results import AnalysisResult, CalibrationResult, Estimate
    from calib.tractor_trailer.derived import derived_sum

    c = np.array(cov) if cov is not None else np.diag([0.01, 0.01])

    def est(name: str, v: float, var: float, ok: bool = True) -> Estimate:
        sd = math.sqrt(var) if math.isfinite(var) else math.nan
        return Estimate(name, v, sd, (v - 1.96 * sd, v + 1.96 * sd), ok)

    total = est("L1+L2", l1 + l2, float(c[0, 0] + c[1, 1] + 2 * c[0, 1]), sum_determined)
    return AnalysisResult(
        robot="tractor_trailer",
        segments=[],
        methods=[],
        estimate=CalibrationResult(
            "PATH",
            {"L1": est("L1", l1, c[0, 0]), "L2": est("L2", l2, c[1, 1])},
            "fit",
            covariance=cov,
            derived=derived_sum(total),
        ),
        source={
            "path": "x.mcap",
            "window": {"index": k, "start_s": 60.0 * (k - 1), "end_s": 60.0 * k},
        },
    )


def _pool(windows: list[object], derive: bool = True) -> object:
    from calib.tractor_trailer.derived import pooled_derived
    from logtools.readers import LogExtent
    from logtools.windows import WindowPlan, pool_windows

    spans = tuple((60.0 * i, 60.0 * (i + 1)) for i in range(len(windows)))
    plan = WindowPlan(0, spans, 60.0, False, LogExtent(0, 10**12, {}), whole=False)
    return pool_windows(
        "x.mcap",
        plan,
        windows,
        [],
        {},  # type: ignore[arg-type]
        derive=pooled_derived if derive else None,
    )


# L1, L2 nearly opposite: the sum far better determined than the split
_COV = [[0.04, -0.0396], [-0.0396, 0.04]]


def test_windows_pool_with_their_covariance_and_the_robot_recomputes_the_sum() -> None:
    rng = np.random.default_rng(3)
    c = np.array(_COV)
    # windows that agree better than their errors say: no between-window spread to add
    draws = rng.multivariate_normal([1.0, 2.5], 0.01 * c, size=4)
    res = _pool([_window(k + 1, *d, _COV) for k, d in enumerate(draws)])
    est = res.estimate  # type: ignore[attr-defined]
    assert est.covariance is not None
    sigma = c / 4  # identical covariances: Sigma / k, the mean of the values
    np.testing.assert_allclose(np.array(est.covariance), sigma, rtol=1e-9)
    assert est.parameters["L1"].value == pytest.approx(draws[:, 0].mean())
    assert est.correlations[0][1] == pytest.approx(-0.99)
    total = est.derived["sum_L1_L2"]
    assert total.value == pytest.approx(draws.sum(axis=1).mean())
    assert total.std == pytest.approx(math.sqrt(sigma.sum()), rel=1e-9)
    assert total.std < 0.2 * est.parameters["L1"].std  # the covariance, not the diagonal
    assert total.identifiable
    stats = res.source["windows"]["pooling"]  # type: ignore[attr-defined]
    assert stats["L1"]["joint"] == ["L1", "L2"]
    assert stats["L1"]["df"] == 6
    assert "jointly by generalised least squares" in est.verdict
    doc = res.to_dict()  # type: ignore[attr-defined]
    np.testing.assert_allclose(np.array(doc["estimate"]["covariance"]), sigma, rtol=1e-9)


def test_windows_that_differ_only_in_the_sum_are_caught_jointly() -> None:
    """Windows whose L1 + L2 differ by 10 of its stds while L1 and L2 each stay within a
    fraction of their own: no per-parameter test sees it, the joint one does, and the pooled
    covariance (so the sum) is widened."""
    sd_sum = math.sqrt(0.04 + 0.04 - 2 * 0.0396)  # 0.028
    vals = [(1.0, 2.5), (1.0, 2.5 + 10 * sd_sum), (1.0, 2.5), (1.0, 2.5 + 10 * sd_sum)]
    res = _pool([_window(k + 1, a, b, _COV) for k, (a, b) in enumerate(vals)])
    stats = res.source["windows"]["pooling"]  # type: ignore[attr-defined]
    assert stats["L1"]["heterogeneous"]
    assert stats["L1"]["parameter_p_heterogeneity"] > 0.05
    assert stats["L2"]["parameter_p_heterogeneity"] > 0.05
    assert any("differ jointly" in w for w in res.warnings)  # type: ignore[attr-defined]
    est = res.estimate  # type: ignore[attr-defined]
    total = est.derived["sum_L1_L2"]
    assert total.std == pytest.approx(math.sqrt(np.sum(est.covariance)), rel=1e-9)
    # the sums' own spread (std 5.8 of theirs) over 4 windows, not their stated 0.028 / 2
    assert total.std > 2 * sd_sum
    assert total.ci95[0] < 3.5 + 5 * sd_sum - 3 * sd_sum  # covers the spread


def test_a_window_without_a_covariance_pools_each_parameter_on_its_own() -> None:
    ws = [_window(1, 1.0, 2.5, _COV), _window(2, 1.1, 2.4, None)]
    res = _pool(ws)
    est = res.estimate  # type: ignore[attr-defined]
    assert est.covariance is None
    assert "not pooled" in est.verdict
    # the sum pooled on its own (inverse-variance over the windows' own sums)
    s1, s2 = (w.estimate.derived["sum_L1_L2"] for w in ws)  # type: ignore[attr-defined]
    w1, w2 = s1.std**-2, s2.std**-2
    assert est.derived["sum_L1_L2"].value == pytest.approx(
        (w1 * s1.value + w2 * s2.value) / (w1 + w2)
    )


def test_a_window_that_does_not_determine_a_parameter_adds_nothing_for_it() -> None:
    nan = math.nan
    ws = [
        _window(1, 1.0, 2.5, [[0.04, 0.01], [0.01, 0.09]]),
        _window(2, 1.3, 2.6, [[0.04, nan], [nan, nan]]),
        _window(3, 1.2, 2.4, [[0.04, 0.01], [0.01, 0.09]]),
    ]
    res = _pool(ws)
    est = res.estimate  # type: ignore[attr-defined]
    stats = res.source["windows"]["pooling"]  # type: ignore[attr-defined]
    assert stats["L1"]["n_logs"] == 3
    assert stats["L2"]["n_logs"] == 2
    assert stats["L2"]["left_out"] == ["window 2 (60-120 s): not determined by this window"]
    assert math.isfinite(est.parameters["L2"].std)
    assert np.isfinite(np.array(est.covariance)).all()


def test_without_the_robots_hook_derived_quantities_are_pooled_on_their_own() -> None:
    ws = [_window(k, 1.0, 2.5, _COV) for k in (1, 2, 3)]
    with_hook = _pool(ws).estimate.derived["sum_L1_L2"]  # type: ignore[attr-defined]
    without = _pool(ws, derive=False).estimate.derived["sum_L1_L2"]  # type: ignore[attr-defined]
    assert with_hook.value == pytest.approx(without.value)
    assert with_hook.std == pytest.approx(without.std, rel=1e-6)  # consistent pieces: equal


def test_one_window_keeps_its_own_estimate() -> None:
    """Pooling a single window changes nothing: its parameters (intervals as the robot gave
    them, widened or one-sided) and covariance are the pooled estimate's."""
    from calib.pooling.estimates import pool_pieces
    from calib.results import CalibrationResult, Estimate

    est = CalibrationResult(
        method="m",
        verdict="v",
        parameters={
            "a": Estimate("a", 4.7, 5.0, (1.13, math.inf), identifiable=False),
            "b": Estimate("b", 1.0, 0.1, (0.8, 1.2)),
        },
        covariance=((25.0, 0.1), (0.1, 0.01)),
    )
    params, derived, cov, _stats, warns = pool_pieces([est], ["w"], "windows", None)
    assert params == dict(est.parameters)
    assert derived == {}
    assert cov is not None
    assert cov.tolist() == [[25.0, 0.1], [0.1, 0.01]]
    assert warns == []
