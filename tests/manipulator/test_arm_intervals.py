"""What the arm's verdict and intervals add to the model-conditional fit: the noise the model's
inputs carry into the torque residual (the encoder's noise through the derivatives, the Coulomb
term's shape at reversals), the processing shifts, the pieces' pooled dispersion, and the catalogue
effects a log cannot exclude. Deterministic facts on small constructed inputs and one simulated
clean log."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest

from calib.adequacy import PieceFit
from calib.manipulator.adequacy import (
    effect_spread,
    pooled_dispersion,
    scaled_by_pieces,
    stabilised,
    unit_scales,
    with_shifts,
)
from calib.manipulator.design import Term, coulomb, term_name
from calib.manipulator.discovery import ArmFitter, arm_catalogue
from calib.manipulator.identify import IdentifyConfig
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.signals import position_noise, prepare_signals
from calib.manipulator.simulate import Friction, Sensors, simulate_planar
from calib.results import Estimate

ARM = Planar2Params()
TERMS = (Term.COULOMB, Term.VISCOUS)
CFG = IdentifyConfig(terms=TERMS, cutoff_hz=20.0)


def _est(name: str, value: float, std: float, unit: str = "kg") -> Estimate:
    return Estimate(name, value, std, (value - 1.96 * std, value + 1.96 * std), True, unit)


@cache
def _fitter() -> ArmFitter:
    run = simulate_planar(ARM, Friction(), duration_s=12.0, sensors=Sensors(), seed=3)
    sig = prepare_signals(run.t_s, run.q, run.tau, cutoff_hz=CFG.cutoff_hz)
    return ArmFitter(Planar2Link(ARM), sig, TERMS, None, CFG)


def test_position_noise_reads_the_quantisation_step() -> None:
    t = np.arange(2000) / 500.0
    step = 2 * np.pi / 2**14
    q = np.round(np.column_stack([np.sin(t), 0.3 * np.cos(2 * t)]) / step) * step
    qf = np.column_stack([np.sin(t), 0.3 * np.cos(2 * t)])
    got = position_noise(t, q, qf, q)
    assert got == pytest.approx(np.full(2, step / math.sqrt(12)), rel=0.15)


def test_signals_carry_one_seeded_noise_draw_through_the_chain() -> None:
    t = np.arange(3000) / 400.0
    q = np.round(np.column_stack([np.sin(t), np.cos(t)]) / 1e-3) * 1e-3
    tau = np.column_stack([np.cos(t), np.sin(t)])
    a = prepare_signals(t, q, tau, cutoff_hz=10.0)
    b = prepare_signals(t, q, tau, cutoff_hz=10.0)
    assert a.noise is not None
    assert b.noise is not None
    for x, y in zip(a.noise, b.noise, strict=True):
        assert x.shape == a.q.shape
        np.testing.assert_array_equal(x, y)
    assert a.q_noise is not None
    assert np.all(a.q_noise > 0)
    # differentiating amplifies the noise; the slice keeps the draw aligned with the samples
    assert np.std(a.noise[2]) > np.std(a.noise[1]) > np.std(a.noise[0])
    s = a.slice(10, 50)
    assert s.noise is not None
    assert s.noise[1].shape == (40, 2)


def test_input_noise_is_the_coulomb_shape_without_an_encoder_draw() -> None:
    f = _fitter()
    fit = f.fit_arm(())
    assert fit is not None
    saved = f.sig
    try:
        f.sig = type(saved)(**{**saved.__dict__, "noise": None})
        got = f.input_noise(fit)
    finally:
        f.sig = saved
    shape = f.coulomb_shape_misfit()
    np.testing.assert_allclose(got, shape, rtol=1e-12)
    # the fitted shape difference is at most the raw one, |Fc| (1 - |tanh(qd / 0.01)|), plus
    # what the refit moves elsewhere; it is not nothing on a log with reversals
    by = dict(zip(fit.names, fit.theta.tolist(), strict=True))
    for j, joint in enumerate(f.model.joint_names):
        fc = by[term_name(Term.COULOMB, joint)]
        bound = math.sqrt(float(np.mean((fc * (1 - np.abs(coulomb(f.sig.qd[:, j])))) ** 2)))
        assert 0 < shape[j] < 2 * bound
    # with the encoder's draw the carried noise only grows
    assert np.all(f.input_noise(fit) >= got - 1e-15)


def test_with_shifts_adds_in_quadrature() -> None:
    est = {"a": _est("a", 1.0, 0.03), "b": _est("b", 2.0, 0.1)}
    out = with_shifts(est, {"a": 0.04, "b": 0.0})
    assert out["a"].std == pytest.approx(0.05)
    assert out["a"].ci95[1] - out["a"].value == pytest.approx(1.959963984540054 * 0.05)
    assert out["a"].identifiable
    assert out["b"] is est["b"]


def _pieces(values: list[float], std: float) -> list[PieceFit]:
    return [PieceFit(float(i), float(i + 1), {"a": v}, {"a": std}) for i, v in enumerate(values)]


def test_pooled_dispersion_scales_the_errors_the_pieces_show() -> None:
    vals = [1.0, 1.2, 0.8, 1.2, 0.8, 1.0]
    k, dof = pooled_dispersion(_pieces(vals, 0.1), ["a"])
    chi2 = sum(((v - 1.0) / 0.1) ** 2 for v in vals)
    assert dof == 5
    assert k == pytest.approx(math.sqrt(chi2 / 5))
    out = scaled_by_pieces({"a": _est("a", 1.0, 0.01)}, _pieces(vals, 0.1))
    assert out["a"].std == pytest.approx(0.01 * k)
    # pieces that agree within their errors leave the estimate alone
    calm = scaled_by_pieces({"a": _est("a", 1.0, 0.01)}, _pieces([1.0, 1.01, 0.99], 0.1))
    assert calm["a"].std == 0.01


def test_unit_scales_judge_a_value_near_zero_by_its_kind() -> None:
    est = {
        "mx": _est("mx", 0.8, 0.01, "kg*m"),
        "my": _est("my", 1e-4, 0.01, "kg*m"),
        "Fc": _est("Fc", 0.3, 0.01, "N*m"),
    }
    sc = unit_scales(est)
    assert sc["my"] == pytest.approx(0.05 * 0.8)
    assert sc["Fc"] == pytest.approx(0.05 * 0.3)


def test_an_unstable_parameter_near_zero_is_judged_against_its_unit_scale() -> None:
    est = {"mx": _est("mx", 0.8, 0.001, "kg*m"), "my": _est("my", 1e-4, 0.001, "kg*m")}
    pieces = [
        PieceFit(float(i), float(i + 1), {"mx": 0.8, "my": v}, {"mx": 0.001, "my": 0.001})
        for i, v in enumerate([0.003, -0.003, 0.003, -0.003, 0.003, -0.003])
    ]
    out = stabilised(est, pieces)
    # widened by the spread (~0.0033) and the overdispersion, still within 25 % of 0.04
    assert out["my"].std > 0.003
    assert out["my"].identifiable
    assert out["mx"] is est["mx"]


def test_effect_spread_leaves_out_alternatives_and_payload() -> None:
    f = _fitter()
    cat = arm_catalogue(f.model.joint_names, f.baseline, nominal=False)
    only_alternatives = tuple(e for e in cat if e.id == str(Term.COULOMB_SMOOTH))
    assert only_alternatives
    assert effect_spread(f, (), only_alternatives) == {}
    offsets = tuple(e for e in cat if e.id == str(Term.OFFSET))
    spread = effect_spread(f, (), offsets)
    assert spread
    assert all(v >= 0 and math.isfinite(v) for v in spread.values())


def test_pipeline_reads_the_joints_at_their_logged_stamps(tmp_path: object) -> None:
    """The aligned frame interpolates a jittered log onto a uniform grid; the arm reads the
    samples as logged (the torque's high-frequency content, hence its noise floor, intact)."""
    from pathlib import Path

    from logtools.load import load_log
    from logtools.robots.manipulator.pipeline import _joints
    from logtools.writers.manipulator import arm_metadata, write_arm_run

    run = simulate_planar(ARM, Friction(), duration_s=4.0, sensors=Sensors(jitter_s=0.0008), seed=5)
    path = Path(str(tmp_path)) / "jitter.mcap"
    write_arm_run(path, run, metadata=arm_metadata(run))
    loaded = load_log(path)
    t, q, tau, n = _joints(loaded)
    assert q.shape == tau.shape
    assert n == 2
    frame_t = (loaded.frame["t_ns"].to_numpy() - loaded.frame["t_ns"][0]) / 1e9
    # the logged stamps keep their jitter; the frame's grid does not
    assert np.std(np.diff(t)) > 10 * np.std(np.diff(frame_t))
    np.testing.assert_allclose(t, run.t_s[: len(t)] - run.t_s[0], atol=2e-9)
    np.testing.assert_allclose(tau, run.tau[: len(t)], rtol=1e-6, atol=1e-6)
