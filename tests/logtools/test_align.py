"""Alignment: properties (hypothesis) and behaviour on gaps, angles and commands."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from logtools.align import AlignMethod, align_signals, find_gaps
from logtools.errors import LogcalInputError, TimestampError

T0 = 1_750_000_000_000_000_000


def _sig(t_ns: np.ndarray, v: np.ndarray) -> pl.DataFrame:
    return pl.DataFrame({"t_ns": np.asarray(t_ns, dtype=np.int64), "value": np.asarray(v, float)})


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(5, 300),
    period_ms=st.integers(1, 200),
    seed=st.integers(0, 2**31 - 1),
    method=st.sampled_from(list(AlignMethod)),
)
def test_aligning_aligned_uniform_signals_is_identity(n, period_ms, seed, method):
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n, dtype=np.int64) * period_ms * 1_000_000
    sig = {name: _sig(t, rng.normal(size=n)) for name in ("v", "omega", "kappa_cmd")}
    out = align_signals(sig, method=method)
    assert out["t_ns"].to_numpy().tolist() == t.tolist()
    for name, frame in sig.items():
        np.testing.assert_array_equal(out[name].to_numpy(), frame["value"].to_numpy())


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(3, 200),
    slope=st.floats(-100, 100),
    icpt=st.floats(-100, 100),
    rate=st.floats(1.0, 500.0),
    seed=st.integers(0, 2**31 - 1),
)
def test_interpolation_is_exact_for_linear_signals(n, slope, icpt, rate, seed):
    rng = np.random.default_rng(seed)
    # irregular source stamps, gaps below the tolerance
    dt = rng.uniform(5e6, 20e6, size=n).astype(np.int64)
    t = T0 + np.cumsum(dt)
    ts = (t - T0) / 1e9
    sig = {"psi": _sig(t, slope * ts + icpt)}
    out = align_signals(sig, rate_hz=rate, tolerance_s=1.0)
    tg = (out["t_ns"].to_numpy() - T0) / 1e9
    np.testing.assert_allclose(out["psi"].to_numpy(), slope * tg + icpt, rtol=1e-9, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(
    sizes=st.lists(st.integers(2, 100), min_size=1, max_size=4),
    rate=st.one_of(st.none(), st.floats(0.5, 1000.0)),
    seed=st.integers(0, 2**31 - 1),
)
def test_output_time_strictly_increasing_within_common_span(sizes, rate, seed):
    rng = np.random.default_rng(seed)
    sig = {}
    for i, n in enumerate(sizes):
        t = T0 + np.sort(rng.choice(10**10, size=n, replace=False)).astype(np.int64)
        t[0], t[-1] = T0 + i * 1000, T0 + 10**10 + i  # overlapping spans
        sig[f"s{i}"] = _sig(np.unique(t), rng.normal(size=np.unique(t).size))
    out = align_signals(sig, rate_hz=rate)
    t = out["t_ns"].to_numpy()
    assert out.schema["t_ns"] == pl.Int64
    assert np.all(np.diff(t) > 0)
    assert t[0] == max(f["t_ns"][0] for f in sig.values())
    assert t[-1] <= min(f["t_ns"][-1] for f in sig.values())


def test_commands_are_held_and_continuous_signals_interpolated():
    t = T0 + np.arange(11) * 100_000_000  # 10 Hz
    cmd = _sig(t[::5], [0.0, 1.0, 2.0])  # 2 Hz command
    v = _sig(t, np.arange(11.0))
    out = align_signals(
        {"kappa_cmd": cmd, "v": v}, rate_hz=20.0, tolerance_s=1.0, hold=["kappa_cmd"]
    )
    k = out["kappa_cmd"].to_numpy()
    tt = (out["t_ns"].to_numpy() - T0) / 1e9
    np.testing.assert_array_equal(k, np.where(tt < 0.5, 0.0, np.where(tt < 1.0, 1.0, 2.0)))
    np.testing.assert_allclose(out["v"].to_numpy(), tt * 10.0, atol=1e-12)


def test_asof_takes_the_nearest_sample():
    t = T0 + np.array([0, 100, 200]) * 1_000_000
    out = align_signals({"v": _sig(t, [0.0, 1.0, 2.0])}, rate_hz=40.0, method=AlignMethod.ASOF)
    # grid 0, 25, 50, 75, ... ms: nearest of 0/100/200 ms (ties go to the earlier sample)
    np.testing.assert_array_equal(out["v"].to_numpy(), [0, 0, 0, 1, 1, 1, 1, 2, 2])


def test_yaw_interpolated_across_the_wrap():
    t = T0 + np.arange(3) * 1_000_000_000
    yaw = np.array([3.0, -3.0, -2.9])  # crosses +-pi between samples 0 and 1
    out = align_signals({"yaw": _sig(t, yaw)}, rate_hz=2.0, wrap=["yaw"])
    mid = out["yaw"][1]
    expected = (np.unwrap(yaw)[0] + np.unwrap(yaw)[1]) / 2
    assert mid == pytest.approx((expected + np.pi) % (2 * np.pi) - np.pi)
    assert abs(mid) > 3.0  # near +-pi, not near 0 as plain interpolation would give
    assert np.all(np.abs(out["yaw"].to_numpy()) <= np.pi)


def test_rows_beyond_tolerance_become_null():
    t = np.concatenate([np.arange(0, 10), np.arange(20, 30)]) * 100_000_000 + T0  # 1 s gap
    out = align_signals(
        {"psi": _sig(t, np.ones(t.size)), "kappa_cmd": _sig(t, np.ones(t.size))}, hold=["kappa_cmd"]
    )
    tt = (out["t_ns"].to_numpy() - T0) / 1e9
    gap = (tt > 0.9 + 0.25 + 1e-9) & (tt < 2.0 - 0.25 - 1e-9)
    assert out["psi"].null_count() == gap.sum() > 0
    assert out["psi"].is_null().to_numpy()[gap].all()
    # the hold covers 2.5 periods after the last sample before the gap
    held = (tt > 0.9 + 0.25 + 1e-9) & (tt < 2.0)
    assert out["kappa_cmd"].is_null().to_numpy()[held].all()


def test_common_span_of_required_signals():
    a = _sig(T0 + np.arange(0, 100) * 10_000_000, np.zeros(100))
    b = _sig(T0 + np.arange(50, 150) * 10_000_000, np.zeros(100))
    out = align_signals({"psi": a, "v": b}, required=["psi"])
    assert out["t_ns"][0] == T0
    assert out["v"].null_count() == 50
    out = align_signals({"psi": a, "v": b})
    assert out["t_ns"][0] == T0 + 50 * 10_000_000
    assert out.height == 50


def test_errors_name_the_signal():
    t = T0 + np.arange(3, dtype=np.int64)
    with pytest.raises(TimestampError, match="'psi'"):
        align_signals({"psi": _sig(t[:1], [1.0])})
    with pytest.raises(TimestampError, match="overlap"):
        align_signals({"psi": _sig(t[:2], [1.0, 2.0]), "v": _sig(t[:2] + 10**9, [1.0, 2.0])})
    with pytest.raises(LogcalInputError):
        align_signals({})


def test_frame_with_several_value_columns():
    t = T0 + np.arange(5) * 100_000_000
    frame = pl.DataFrame({"t_ns": t, "0": np.arange(5.0), "1": -np.arange(5.0)})
    out = align_signals({"q": frame})
    assert out.columns == ["t_ns", "q.0", "q.1"]
    np.testing.assert_array_equal(out["q.1"].to_numpy(), -np.arange(5.0))


def test_gaps_do_not_depend_on_sample_order_or_repeated_stamps():
    rng = np.random.default_rng(2)
    t = T0 + np.arange(2000, dtype=np.int64) * 10_000_000
    t = np.delete(t, np.s_[500:700])  # a 2 s dropout
    messy = rng.permutation(np.concatenate([t, t[::7]]))  # shuffled, some stamps twice
    gaps = find_gaps({"a": t})
    assert len(gaps) == 1
    assert gaps[0].duration_s == pytest.approx(2.01)
    assert find_gaps({"a": messy}) == gaps
    assert find_gaps({"a": np.concatenate([t[:1000], t[999:]])}) == gaps  # sorted, one repeat
