"""An effect added to the differential drive the way a user would: its catalogue entry and its
hook defined here, in the test, registered with one line; nothing else of the package knows it.

The effect: the right encoder counts (1 + g) of the wheel's turn while the wheel turns
backwards (a quadrature decoder that gains ticks in one direction). Unlike a radius asymmetry it
leaves forward driving untouched. The log carrying it is a clean simulated log whose right-wheel
readings this test transforms with its own code. Deterministic (fixed seeds)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np
import pytest
from numpy.typing import NDArray

from calib.diff_drive.data import DriveRun
from calib.diff_drive.effects import (
    DriveEffect,
    DriveEffectModel,
    catalogue,
    discover_effects,
    register_effect,
    unregister_effect,
)
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import fit_lsq
from calib.diff_drive.sim import SimConfig, mixed_commands, simulate_diff_drive
from calib.discovery import EffectKind, EffectParam, EffectSpec

Array = NDArray[np.float64]
NOM = DiffDriveParams(0.042, 0.042, 0.20)
GAIN = 0.05


class BackwardGain(DriveEffect):
    """The true right-wheel turn is the logged one over (1 + g) where it is negative."""

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        g = values["g"]
        return np.where(dr < 0, dr / (1 + g), dr), dl


BACKWARD_GAIN: EffectSpec[DriveEffectModel] = EffectSpec(
    "encoder_backward_gain",
    "wheel_right",
    EffectKind.SENSOR,
    (EffectParam("g", "1", 0.0, -0.5, 0.5, 0.0),),
    "the right encoder counts (1 + g) of the wheel's turn while it turns backwards",
    confounded_with=("wheel_radius_asymmetry(wheels)",),
    model=BackwardGain(),
)


@pytest.fixture
def registered() -> Iterator[None]:
    register_effect(BACKWARD_GAIN)
    yield
    unregister_effect(BACKWARD_GAIN)


def _clean(seed: int) -> DriveRun:
    cfg = SimConfig(NOM, NOM, slip_std=0.005, counts_per_rev=2797, pose_noise=(0.001, 0.001, 0.002))
    s = simulate_diff_drive(mixed_commands(NOM, 180.0, np.random.default_rng(seed)), cfg, seed)
    return DriveRun(s.t, s.wheel_right, s.wheel_left, s.x, s.y, s.yaw)


def _with_backward_gain(run: DriveRun, g: float) -> DriveRun:
    """The right wheel's backward increments read (1 + g) times as large."""
    d = np.diff(run.wheel_right)
    d = np.where(d < 0, d * (1 + g), d)
    wr = run.wheel_right[0] + np.concatenate([[0.0], np.cumsum(d)])
    return DriveRun(run.t, wr, run.wheel_left, run.x, run.y, run.yaw)


def test_registration_is_one_line_and_reversible(registered: None) -> None:
    keys = [e.key for e in catalogue(True)]
    assert keys[-1] == "encoder_backward_gain(wheel_right)"
    assert keys.count("encoder_backward_gain(wheel_right)") == 1
    register_effect(BACKWARD_GAIN)  # twice is once
    assert [e.key for e in catalogue(True)].count("encoder_backward_gain(wheel_right)") == 1
    unregister_effect(BACKWARD_GAIN)
    assert "encoder_backward_gain(wheel_right)" not in [e.key for e in catalogue(True)]
    with pytest.raises(ValueError, match="no model hook"):
        register_effect(EffectSpec("no_hook", "x", EffectKind.SENSOR, (), "nothing"))


def test_log_with_the_effect_names_it_and_the_heldout_fit_improves(registered: None) -> None:
    run = _with_backward_gain(_clean(7), GAIN)
    backwards = np.diff(run.wheel_right) < 0
    assert 0.03 < backwards.mean() < 0.5  # the log turns the right wheel backwards at times
    fit = fit_lsq([run], n_boot=50)
    d = discover_effects([run], NOM, calibrated=fit.params, marker=fit.offset)
    assert d.named[0] == "encoder_backward_gain"
    sel = d.selection
    assert sel is not None
    g = sel.final.effect_parameters["encoder_backward_gain(wheel_right)"]["g"]
    assert g.ci95[0] < GAIN < g.ci95[1]
    assert g.ci95[0] > 0
    assert sel.final.heldout_sse < 0.8 * sel.base.heldout_sse
    # the radii it implies are the true ones (a radius asymmetry would have bent them)
    r_R = sel.final.parameters["wheel_radius_right"]
    assert r_R.ci95[0] < NOM.r_R < r_R.ci95[1]


def test_clean_log_does_not_accept_it(registered: None) -> None:
    run = _clean(7)
    fit = fit_lsq([run], n_boot=50)
    d = discover_effects([run], NOM, calibrated=fit.params, marker=fit.offset)
    assert d.selection is not None
    tried = {t.key: t for t in d.selection.tried}
    assert "encoder_backward_gain(wheel_right)" in tried
    assert not tried["encoder_backward_gain(wheel_right)"].accepted
    assert d.named == []


def test_extra_argument_without_registration() -> None:
    run = _with_backward_gain(_clean(7), GAIN)
    fit = fit_lsq([run], n_boot=50)
    plain = discover_effects([run], NOM, calibrated=fit.params, marker=fit.offset)
    assert "encoder_backward_gain" not in plain.named
    d = discover_effects(
        [run], NOM, calibrated=fit.params, marker=fit.offset, extra=(BACKWARD_GAIN,)
    )
    assert d.named[0] == "encoder_backward_gain"
