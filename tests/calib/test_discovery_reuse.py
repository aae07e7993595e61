"""Discovery's model remembers intermediate results: the remembered path must give
exactly what a fresh computation gives, and the compiled half-grid integration exactly what
the numpy steps give."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from sim_frame import aligned_frame_from_run  # type: ignore[import-not-found]

import calib.tractor_trailer.discovery.model as model
from calib.tractor_trailer.discovery import catalogue
from calib.tractor_trailer.discovery.data import DiscoveryData, prepare_data
from calib.tractor_trailer.discovery.effects import ActuatorLag
from calib.tractor_trailer.discovery.fit import fit_model
from calib.tractor_trailer.discovery.model import ModelSpec, integrate_hitch_half, predict
from calib.tractor_trailer.models.hitch_rk4 import compiled_available
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import NoiseSpec, SpeedProfile, TractorTrailerSim
from calib.tractor_trailer.sim.tractor_trailer import simulate_tractor_trailer as simulate


@pytest.fixture(scope="module")
def data() -> DiscoveryData:
    cmds = CommandSequence(
        [
            CommandSpec(CommandType.HARMONIC, 30.0, 0.2, 0.2),
            CommandSpec(CommandType.STEP, 20.0, 0.15),
        ]
    )
    speed = SpeedProfile(1.5, variation=0.3)
    cfg = TractorTrailerSim(commands=cmds, speed=speed, noise=NoiseSpec.none())
    d = prepare_data(aligned_frame_from_run(simulate(cfg, seed=5)))
    # restarts from a recorded angle on both grids, so that the sensor effects reach psi0
    # and the anchors
    return replace(d, anchors={700: 0.05}, anchors_d={70: 0.05})


def _half_grid_case(gap_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, float]]:
    """200 samples 1/8 s apart with a gap of ``gap_s`` before sample 120 (restarted there; the
    samples are the same whatever the gap, the times exact in binary), speeds up to 3 m/s:
    steps that need sub-steps for short relaxation lengths."""
    rng = np.random.default_rng(7)
    t0 = np.arange(200) * 0.125
    k = 0.3 * np.sin(0.7 * t0) + 0.02 * rng.normal(size=t0.size)
    v = 1.5 + 1.5 * np.sin(0.3 * t0)
    t = t0 + np.where(np.arange(200) >= 120, gap_s, 0.0)
    half = [model._with_midpoints(np.asarray(x, dtype=float)) for x in (t, k, v)]
    return half[0], half[1], half[2], {0: 0.02, 120: -0.1, 199: 0.3}


@pytest.mark.skipif(not compiled_available(), reason="compiled loops not built")
@pytest.mark.parametrize("lam", [30.0, 2.5, 0.3, 0.05])
def test_compiled_half_grid_integration_is_the_numpy_steps(
    lam: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    th, kh, vh, anchors = _half_grid_case(4.0)
    compiled = integrate_hitch_half(th, kh, vh, 1.2, 2.5, lam, 0.01, anchors)
    monkeypatch.setattr(model, "rk4_hitch_half", lambda *a, **k: None)
    steps = integrate_hitch_half(th, kh, vh, 1.2, 2.5, lam, 0.01, anchors)
    assert np.array_equal(compiled, steps)
    assert [compiled[0], compiled[120], compiled[199]] == [0.02, -0.1, 0.3]


@pytest.mark.parametrize("numpy_steps", [False, True])
def test_the_step_into_a_restart_does_not_matter(
    numpy_steps: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The state is replaced at a restart: how long the gap before it is (how many sub-steps
    it would take) changes nothing, on either path."""
    if numpy_steps:
        monkeypatch.setattr(model, "rk4_hitch_half", lambda *a, **k: None)
    short = integrate_hitch_half(*_half_grid_case(1.0)[:3], 1.2, 2.5, 0.3, 0.01, {120: -0.1})
    long = integrate_hitch_half(*_half_grid_case(4096.0)[:3], 1.2, 2.5, 0.3, 0.01, {120: -0.1})
    assert np.array_equal(short, long)


def _spec(pool_keys: list[str]) -> ModelSpec:
    pool = {e.key: e for e in catalogue("transient")}
    return ModelSpec("transient", tuple(pool[k] for k in pool_keys))


@pytest.mark.parametrize("how", ["grid", "full_rate", "fine"])
def test_remembered_steps_give_the_fresh_results(data: DiscoveryData, how: str) -> None:
    """Every parameter varied in turn (as a finite-difference Jacobian does, and by a large
    step): the model evaluated on data that remembers earlier evaluations equals the model on
    fresh data with fresh effects, to the bit."""
    keys = [e.key for e in catalogue("transient")]
    spec = _spec(keys)
    theta = np.array([1.25, 2.48, 0.02, 0.001, 1.03, 0.97, 0.15, 0.2, 0.01, 0.05, 0.04])
    assert theta.size == len(spec.param_names)
    kw = {"full_rate": how == "full_rate", "fine": how == "fine"}
    predict(spec, theta, data, **kw)
    for i in range(theta.size):
        for step in (1.5e-8 * max(1.0, abs(theta[i])), 0.05 * max(abs(theta[i]), 0.02)):
            th = theta.copy()
            th[i] += step
            warm = predict(spec, th, data, **kw)
            cold = predict(_spec(keys), th, replace(data), **kw)
            for c in data.channels:
                assert np.array_equal(warm[c], cold[c]), (spec.param_names[i], c)
            predict(spec, theta, data, **kw)  # back to the point, as the next column is


def test_remembered_results_are_shared_read_only(data: DiscoveryData) -> None:
    spec = _spec(["actuator_lag", "sensor_offset(psi)"])
    a = predict(spec, [1.25, 2.48, 0.2, 0.01], data)
    b = predict(spec, [1.25, 2.48, 0.2, 0.01], data)
    assert a["psi"] is b["psi"]
    with pytest.raises(ValueError, match="read-only"):
        a["psi"][0] = 1.0
    f = fit_model(spec, data, [1.25, 2.48, 0.2, 0.01], data.train_mask(), tol=1e-6)
    assert fit_model(spec, data, [1.25, 2.48, 0.2, 0.01], data.train_mask(), tol=1e-6) is f
    assert fit_model(spec, data, [1.25, 2.48, 0.2, 0.01], data.test_mask(), tol=1e-6) is not f
    assert not f.theta.flags.writeable
    assert not f.jac.flags.writeable


def test_an_effect_does_not_remember_what_may_still_change(data: DiscoveryData) -> None:
    """Only read-only inputs are remembered: a caller's array changed in place between two
    calls gives the new answer."""
    lag = ActuatorLag()
    kappa = np.array(data.kappa_h)  # writeable copy
    first = lag.modify_inputs(data.th_s, kappa, data.v_h, {"time_constant": 0.3})[0].copy()
    kappa *= 2.0
    second = lag.modify_inputs(data.th_s, kappa, data.v_h, {"time_constant": 0.3})[0]
    assert np.allclose(second, 2.0 * first, rtol=1e-12, atol=1e-15)
    assert not np.allclose(second, first)
