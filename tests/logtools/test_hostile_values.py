"""Hostile values in structurally valid logs: near-duplicate stamps, single wild
samples, impossible magnitudes. Each has a bounded cost and a named outcome."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest

from logtools.align import align_signals, median_rate_hz
from logtools.errors import LogcalInputError, SignalValueError
from logtools.load import load_log
from logtools.outliers import outlier_mask
from logtools.problems import ProblemKind

RATE_HZ = 50.0
N = 1200


def _frame(t_ns: np.ndarray, v: np.ndarray) -> pl.DataFrame:
    return pl.DataFrame({"t_ns": pl.Series(t_ns, dtype=pl.Int64), "value": v})


def _times(n: int = N) -> np.ndarray:
    return (np.arange(n) * (1e9 / RATE_HZ)).astype(np.int64)


@pytest.mark.parametrize("step_ns", [1000, 1])
def test_duplicate_one_microsecond_later_keeps_the_grid_at_the_log_rate(step_ns):
    t = _times()
    dup = np.sort(np.concatenate([t, t + step_ns]))
    assert median_rate_hz(dup) == pytest.approx(RATE_HZ, rel=1e-3)
    v = np.sin(dup * 1e-9)
    out = align_signals({"v": _frame(dup, v), "omega": _frame(t, np.cos(t * 1e-9))})
    assert out.height == N  # not 20,000 x N rows
    assert out["v"].null_count() == 0


def test_a_grid_rate_far_beyond_the_log_is_refused():
    t = _times()
    with pytest.raises(LogcalInputError, match="most-sampled signal"):
        align_signals({"v": _frame(t, np.ones(N))}, rate_hz=1e9)


def _speed(rng: np.random.Generator) -> np.ndarray:
    return 1.5 + 0.3 * np.sin(np.arange(N) / 90.0) + 0.01 * rng.standard_normal(N)


@pytest.mark.parametrize("bad", [100.0, -100.0, 1e4, 1e7, 1e308, -1e308])
@pytest.mark.parametrize("at", [0, 1, 600, N - 1])
def test_one_wild_speed_sample_is_found(bad, at):
    v = _speed(np.random.default_rng(1))
    clean = outlier_mask(_times(), v)
    v[at] = bad
    mask = outlier_mask(_times(), v)
    if at in (0, N - 1) and abs(bad) < 1e4:
        # at an end only the gross test applies: 100 m/s next to 1.5 m/s is below it
        assert not mask[[i for i in range(N) if i != at]].any()
    else:
        assert np.flatnonzero(mask).tolist() == [at]
    assert not clean.any()


def test_command_steps_are_not_outliers():
    k = np.repeat([0.0, 0.1, -0.1, 0.05, 0.0, 0.2], N // 6)
    assert not outlier_mask(_times(), k).any()
    k[300] = 5.0  # one sample away and back: a glitch
    assert np.flatnonzero(outlier_mask(_times(), k)).tolist() == [300]


def _csv(path, v: np.ndarray) -> None:
    t = np.arange(v.size) / RATE_HZ
    kappa = np.repeat([0.0, 0.05, -0.05, 0.0], -(-v.size // 4))[: v.size]
    psi = 0.3 * np.tanh(kappa * 10)
    lines = ["t,kappa_cmd,v,psi"]
    rows = zip(t.tolist(), kappa.tolist(), v.tolist(), psi.tolist(), strict=True)
    lines += [f"{a!r},{b!r},{c!r},{d!r}" for a, b, c, d in rows]
    path.write_text("\n".join(lines) + "\n")


def test_load_excludes_a_wild_sample_and_names_its_time(tmp_path):
    v = _speed(np.random.default_rng(2))
    v[700] = 1e308
    _csv(tmp_path / "a.csv", v)
    loaded = load_log(tmp_path / "a.csv")
    [p] = [p for p in loaded.problems if p.kind is ProblemKind.OUTLIER]
    assert (p.topic, p.count, p.t0_ns) == ("v", 1, round(700 / RATE_HZ * 1e9))
    assert "14.000 s" in p.message
    assert loaded.frame["v"].drop_nulls().abs().max() < 3.0


def test_a_signal_in_an_impossible_unit_is_refused(tmp_path):
    _csv(tmp_path / "b.csv", _speed(np.random.default_rng(3)) * 1e300)
    with pytest.raises(SignalValueError, match=r"signal 'v' .* beyond \+-1000 m/s"):
        load_log(tmp_path / "b.csv")
