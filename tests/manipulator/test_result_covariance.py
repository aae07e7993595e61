"""The arm's results carry the HAC covariance of the base parameters their intervals come from,
NaN in the rows of parameters the log does not determine (as their standard errors are)."""

from __future__ import annotations

import numpy as np

from calib.manipulator.identify import identify_arm
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.simulate import Friction, Sensors, simulate_planar


def test_arm_results_carry_the_hac_covariance() -> None:
    p = Planar2Params(payload=0.2)
    run = simulate_planar(
        p,
        Friction(coulomb=(0.1, 0.15), viscous=(0.1, 0.05)),
        duration_s=10.0,
        sensors=Sensors(),
        seed=2,
    )
    res = identify_arm(Planar2Link(p), run.t_s, run.q, run.tau)
    rec = res.recommended
    assert rec.parameter_names == tuple(res.design.names)
    cov = np.array(rec.covariance, dtype=float)
    ok = np.array([e.identifiable for e in rec.parameters.values()])
    assert ok.any()
    np.testing.assert_allclose(cov[np.ix_(ok, ok)], res.wls.cov[np.ix_(ok, ok)], rtol=1e-12)
    assert np.isnan(cov[~ok]).all()
    assert np.isnan(cov[:, ~ok]).all()
    std = np.array([e.std for e in rec.parameters.values()])
    np.testing.assert_allclose(np.sqrt(np.diag(cov))[ok], std[ok], rtol=1e-12)
    corr = np.array(rec.correlations, dtype=float)[np.ix_(ok, ok)]
    np.testing.assert_allclose(corr, corr.T)
    assert np.all(np.abs(corr) <= 1.0)
    for m in res.methods:  # each method's interval comes from its own (or the OLS) covariance
        assert m.covariance is not None
        assert len(m.covariance) == len(m.parameters)
