"""The shared adequacy core (calib.adequacy) on inputs whose answer is known by construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.adequacy import (
    EXPLAINS,
    NOT_ASSESSED,
    NOT_EXPLAINED,
    PieceFit,
    ResidualChannel,
    assess,
    noise_floor,
    parameter_change,
    span,
    under_misfit,
)
from calib.discovery import EffectKind, EffectParam, EffectSpec, ModelFit, select_effects
from calib.results import Estimate

T = np.arange(0.0, 60.0, 0.02)


def _white(seed: int, std: float) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, std, T.size)


def test_noise_floor_reads_white_noise() -> None:
    r = _white(1, 0.01)
    nf = noise_floor(T, r)
    assert nf.std == pytest.approx(0.01, rel=0.1)
    assert nf.source == "high-frequency content"


def test_noise_floor_ignores_a_slow_model_error() -> None:
    r = _white(2, 0.01) + 0.2 * np.sin(0.5 * T)  # a large, slow misfit
    assert noise_floor(T, r).std == pytest.approx(0.01, rel=0.15)


def test_noise_floor_is_never_below_the_quantisation() -> None:
    true = 0.3 * np.sin(T / 5.0)
    rec = np.round(true / 0.01) * 0.01
    nf = noise_floor(T, rec - true, measured=rec)
    assert nf.quantum == pytest.approx(0.01)
    assert nf.std >= 0.01 / math.sqrt(12.0) * 0.999
    assert nf.source.startswith("quantisation")


def test_noise_floor_adds_the_inputs_noise_in_quadrature() -> None:
    r = _white(3, 0.01)
    base = noise_floor(T, r).std
    assert noise_floor(T, r, input_std=0.02).std == pytest.approx(math.hypot(base, 0.02))


def test_white_residual_is_explained() -> None:
    a = assess([ResidualChannel("psi", "rad", T, _white(4, 0.01))], model="m")
    assert a.verdict == EXPLAINS
    assert a.located == ()
    assert a.to_dict()["verdict"] == "explains"


def test_structured_residual_is_not_explained_and_located_in_time() -> None:
    r = _white(5, 0.01) + 0.05 * np.sin(0.3 * T) * (T > 30.0)
    a = assess([ResidualChannel("psi", "rad", T, r)], model="m")
    assert a.verdict == NOT_EXPLAINED
    assert a.located, "a misfit in the second half is located"
    assert all(loc.axis == "time" and loc.lo >= 29.0 for loc in a.located)
    assert "does not explain" in a.summary


def test_misfit_located_along_a_covariate() -> None:
    speed = np.abs(np.sin(T / 7.0)) * 3.0
    r = _white(6, 0.01) + 0.08 * (speed > 2.4)
    a = assess([ResidualChannel("psi", "rad", T, r, covariates={"speed (m/s)": speed})], model="m")
    axes = {loc.axis for loc in a.located}
    assert "speed (m/s)" in axes
    top = next(loc for loc in a.located if loc.axis == "speed (m/s)")
    assert top.lo >= 2.0


def test_heldout_residual_is_the_one_judged() -> None:
    r = _white(7, 0.01)
    held = r * 3.0
    a = assess([ResidualChannel("psi", "rad", T, r, heldout=held)], model="m")
    assert a.channels[0].ratio < 1.5 < a.channels[0].judged_ratio
    assert a.verdict == NOT_EXPLAINED


def test_too_few_samples_is_not_assessed() -> None:
    a = assess([ResidualChannel("psi", "rad", T[:5], _white(8, 0.01)[:5])], model="m")
    assert a.verdict == NOT_ASSESSED
    assert "fewer than" in a.reason


def test_under_misfit_widens_and_undetermines_only_under_a_misfit() -> None:
    e = Estimate("L1", 1.2, 0.01, (1.18, 1.22))
    good = assess([ResidualChannel("psi", "rad", T, _white(9, 0.01))], model="m")
    assert under_misfit(e, good) is e
    bad = assess([ResidualChannel("psi", "rad", T, _white(9, 0.01) * 4.0 + 0.0)], model="m")
    bad_r = _white(10, 0.01) + 0.05 * np.sin(0.3 * T)
    bad = assess([ResidualChannel("psi", "rad", T, bad_r)], model="m")
    w = under_misfit(e, bad, pieces=[1.1, 1.3])
    assert not w.identifiable
    assert w.std > e.std * bad.misfit_factor * 0.99
    assert w.ci95[0] < 1.1
    assert w.ci95[1] > 1.3
    assert "does not explain" in w.note


def test_parameter_change_finds_a_step_and_not_a_constant() -> None:
    rng = np.random.default_rng(11)
    step = [
        PieceFit(
            10.0 * i,
            10.0 * (i + 1),
            {"L2": (2.5 if i < 5 else 3.0) + rng.normal(0, 0.02)},
            {"L2": 0.02},
        )
        for i in range(8)
    ]
    ch = parameter_change(step, ["L2"])
    assert ch is not None
    assert ch.t_s == pytest.approx(50.0)
    assert ch.before["L2"] == pytest.approx(2.5, abs=0.05)
    assert ch.after["L2"] == pytest.approx(3.0, abs=0.05)
    flat = [
        PieceFit(10.0 * i, 10.0 * (i + 1), {"L2": 2.5 + rng.normal(0, 0.02)}, {"L2": 0.02})
        for i in range(8)
    ]
    assert parameter_change(flat, ["L2"]) is None
    assert parameter_change(flat[:3], ["L2"]) is None  # too few pieces to tell


def test_span_covers_both_explanations() -> None:
    a = Estimate("L1", 1.25, 0.01, (1.23, 1.27))
    b = Estimate("L1", 1.56, 0.02, (1.52, 1.60))
    s = span([a, b], ["actuator_delay", "clock_offset x2"])
    assert s.ci95 == (1.23, 1.60)
    assert not s.identifiable
    assert "clock_offset x2" in s.note


# --- selection on a toy linear model: y = g * x + b + noise, gain g the robot's parameter ----

X = np.linspace(-1.0, 1.0, 400)
OFFSET = EffectSpec(
    "sensor_offset",
    "y",
    EffectKind.SENSOR,
    (EffectParam("offset", "", 0.0, -1.0, 1.0, 0.0),),
    "y reads offset high",
)
CUBIC = EffectSpec(
    "nonlinearity",
    "y",
    EffectKind.SENSOR,
    (EffectParam("c3", "", 0.0, -1.0, 1.0, 0.0),),
    "y has a cubic term",
)


def _fitter(y: np.ndarray, sigma: float):  # type: ignore[no-untyped-def]
    held = np.arange(X.size) % 4 == 0

    def fit(effects: tuple[EffectSpec, ...]) -> ModelFit:
        cols = [X]
        names = ["gain"]
        for e in effects:
            cols.append(np.ones_like(X) if e.id == "sensor_offset" else X**3)
            names.append(e.key)
        A = np.column_stack(cols)
        coef = np.linalg.lstsq(A[~held], y[~held], rcond=None)[0]
        r_train = y[~held] - A[~held] @ coef
        r_held = y[held] - A[held] @ coef
        cov = np.linalg.inv(A[~held].T @ A[~held]) * sigma**2
        est = {
            n: Estimate(n, float(c), float(math.sqrt(cov[i, i])), (0, 0))
            for i, (n, c) in enumerate(zip(names, coef, strict=True))
        }
        eff = {e.key: {e.params[0].name: est[e.key]} for e in effects}
        return ModelFit(
            effects,
            {"gain": est["gain"]},
            eff,
            float((r_train**2).sum() / sigma**2),
            float((r_held**2).sum() / sigma**2),
            int((~held).sum()),
            len(names),
        )

    return fit


def test_selection_names_the_true_effect_and_nothing_on_clean_data() -> None:
    rng = np.random.default_rng(12)
    y = 2.0 * X + 0.1 + rng.normal(0.0, 0.01, X.size)
    sel = select_effects(_fitter(y, 0.01), [OFFSET, CUBIC])
    assert sel is not None
    assert sel.final.keys == ("sensor_offset(y)",)
    clean = 2.0 * X + rng.normal(0.0, 0.01, X.size)
    sel = select_effects(_fitter(clean, 0.01), [OFFSET, CUBIC])
    assert sel is not None
    assert sel.final.keys == ()


def test_selection_reports_a_confound_that_moves_the_parameter() -> None:
    # y = 2 x + 0.3 x^3: a cubic; at |x| <= 1 a cubic term competes with the gain. Two
    # explanations that the data cannot tell apart are built by making the candidates identical
    # in fit but different in the gain they imply (a duplicate cubic under another name whose
    # fit moves the gain is what a confound looks like).
    rng = np.random.default_rng(13)
    y = 2.0 * X + 0.3 * X**3 + rng.normal(0.0, 0.01, X.size)
    twin = EffectSpec(
        "other_cubic",
        "y",
        EffectKind.DYNAMICS,
        (EffectParam("c3", "", 0.0, -1.0, 1.0, 0.0),),
        "a twin",
    )
    base = _fitter(y, 0.01)

    def fit(effects: tuple[EffectSpec, ...]) -> ModelFit | None:
        swapped = tuple(CUBIC if e.id == "other_cubic" else e for e in effects)
        if len(set(swapped)) < len(swapped):
            return None  # the twin beside the cubic: a singular fit, which the engine skips
        f = base(swapped)
        if any(e.id == "other_cubic" for e in effects):
            g = f.parameters["gain"]
            moved = Estimate("gain", g.value + 0.5, g.std, g.ci95)
            key = {"nonlinearity(y)": "other_cubic(y)"}
            return ModelFit(
                effects,
                {"gain": moved},
                {key.get(k, k): v for k, v in f.effect_parameters.items()},
                f.sse + 1.0,
                f.heldout_sse,
                f.n,
                f.k,
            )
        return f

    sel = select_effects(fit, [CUBIC, twin])
    assert sel is not None
    assert sel.final.keys == ("nonlinearity(y)",)
    assert len(sel.confounds) == 1
    c = sel.confounds[0]
    assert c.alternative == "other_cubic(y)"
    assert "gain" in c.parameters


def test_pooled_runs_are_not_explained_when_one_run_is_not() -> None:
    from calib.adequacy import combine_runs

    good = assess([ResidualChannel("psi", "rad", T, _white(14, 0.01))], model="m")
    bad = assess([ResidualChannel("psi", "rad", T, _white(15, 0.01) + 0.05 * np.sin(T))], model="m")
    assert combine_runs([("a", good), ("b", good)], "m").verdict == EXPLAINS
    both = combine_runs([("a", good), ("b", bad)], "m")
    assert both.verdict == NOT_EXPLAINED
    assert "b" in both.notes[0]
    assert "a" not in both.notes[0].split("run(s)")[1]
    assert combine_runs([("a", None)], "m").verdict == NOT_ASSESSED


def test_noise_floor_of_a_mostly_resting_signal_does_not_collapse() -> None:
    rng = np.random.default_rng(16)
    r = np.where(rng.random(T.size) < 0.85, 0.0, rng.normal(0.0, 0.05, T.size))
    assert noise_floor(T, r).std > 0.01  # the MAD alone would read 0


def test_parameter_change_ignores_a_tiny_or_drifting_difference() -> None:
    tiny = [
        PieceFit(10.0 * i, 10.0 * (i + 1), {"m": 1.0 + (0.002 if i >= 4 else 0.0)}, {"m": 1e-5})
        for i in range(8)
    ]
    assert parameter_change(tiny, ["m"]) is None  # 0.2 %: below min_relative
    drift = [
        PieceFit(10.0 * i, 10.0 * (i + 1), {"m": 1.0 + 0.05 * i}, {"m": 1e-3}) for i in range(8)
    ]
    assert parameter_change(drift, ["m"]) is None  # a steady drift is not one change


def test_piece_stability_widens_only_a_parameter_that_scatters() -> None:
    from calib.adequacy import piece_stability, widen_unstable

    rng = np.random.default_rng(17)
    pieces = [
        PieceFit(
            10.0 * i,
            10.0 * (i + 1),
            {"a": 1.0 + rng.normal(0, 0.01), "b": 2.0 + 0.2 * (-1) ** i},
            {"a": 0.01, "b": 0.01},
        )
        for i in range(6)
    ]
    st = piece_stability(pieces, ["a", "b"])
    assert not st["a"].unstable
    assert st["b"].unstable
    assert st["b"].factor > 10
    est = {
        "a": Estimate("a", 1.0, 0.004, (0.992, 1.008)),
        "b": Estimate("b", 2.0, 0.004, (1.992, 2.008)),
    }
    w = widen_unstable(est, st, rel_tol=0.05)
    assert w["a"] is est["a"]
    assert w["b"].std > 0.2
    assert not w["b"].identifiable
    assert w["b"].ci95[0] < 1.8
