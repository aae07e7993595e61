"""Adequacy and discovery along the measured path (calib.tractor_trailer.path_discovery) on
logs from the independent generator: a clean log is explained and determined; a joint-angle
offset, backlash, a gain and a trailer swapped mid-log make the nominal model "not explain" the
log, and the effect is named (or the change located) while the final estimate either covers the
truth or is not determined."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from indgen.tractor_kinds import tractor_log

from calib.results import CalibrationResult, Estimate
from calib.tractor_trailer.estimators.drive_path import DrivePath
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.path_discovery import (
    PathDiscovery,
    discover_along_path,
    judge_path_fit,
    recommended,
)
from calib.tractor_trailer.path_effects import JointPathModel, effect_by_key


def _inputs(log) -> tuple[DrivePath, np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    hitch = log.streams["/hitch/angle"]
    t0 = min(s.stamps_ns[0] for s in log.streams.values())
    pose = log.streams["/pose"]
    path = DrivePath.from_pose(
        (pose.stamps_ns - t0) / 1e9,
        pose.fields["x"],
        pose.fields["y"],
        np.unwrap(pose.fields["yaw"]),
        smooth_samples=3,
    )
    return path, (hitch.stamps_ns - t0) / 1e9, hitch.fields["angle"]


def _run(
    seed: int, kind: str | None = None, magnitude: float = 0.0, offset: float = 0.0
) -> tuple[PathDiscovery, CalibrationResult, dict]:  # type: ignore[type-arg]
    log = tractor_log(seed, kind, magnitude)
    path, t, psi = _inputs(log)
    fit = PathTransientFit().fit(path, t, psi + offset)
    disc = discover_along_path(path, t, psi + offset, [], fit)
    return disc, recommended(fit.result_, disc), log.truth


def _covers_or_undetermined(e: Estimate, truth: float) -> bool:
    return (not e.identifiable) or e.ci95[0] <= truth <= e.ci95[1]


def test_clean_log_is_explained_and_determined() -> None:
    disc, est, truth = _run(2)
    assert disc.nominal is not None
    assert disc.nominal.verdict == "explains"
    assert disc.adequacy is not None
    assert disc.adequacy.explains
    assert disc.accepted == ()
    assert disc.change is None
    for name in ("L1", "L2"):
        e = est.parameters[name]
        assert e.identifiable, e
        assert e.ci95[0] <= truth[name] <= e.ci95[1], (name, e, truth[name])
    json.dumps(disc.to_dict())  # JSON-safe


def test_psi_offset_is_named_and_the_estimate_covers_the_truth() -> None:
    disc, est, truth = _run(2, offset=0.035)
    assert disc.nominal is not None
    assert disc.nominal.verdict == "does not explain"
    assert "sensor_offset(psi)" in [e.key for e in disc.accepted]
    assert disc.selection is not None
    off = disc.selection.final.effect_parameters["sensor_offset(psi)"]["offset"]
    assert off.ci95[0] <= 0.035 <= off.ci95[1]
    assert disc.adequacy is not None
    assert disc.adequacy.explains
    assert disc.adequacy.before is disc.nominal
    assert est.method.endswith("sensor_offset(psi)")
    for name in ("L1", "L2"):
        assert _covers_or_undetermined(est.parameters[name], truth[name])


@pytest.mark.parametrize("seed", [1, 2])
def test_backlash_is_named_not_a_clock_offset(seed: int) -> None:
    """Play of 0.03 rad in the hitch encoder: named as backlash (seed 1: the nominal model does
    not explain the log; seed 2: it does, within 1.5x the floor, but L1 is 23 % low and the
    named backlash moves it back)."""
    disc, est, truth = _run(seed, "hitch_backlash", 0.03)
    assert disc.nominal is not None
    assert disc.nominal.verdict == ("does not explain" if seed == 1 else "explains")
    assert [e.key for e in disc.accepted] == ["backlash(psi)"]
    assert disc.selection is not None
    w = disc.selection.final.effect_parameters["backlash(psi)"]["width"]
    assert 0.02 < w.value < 0.045
    for name in ("L1", "L2"):
        assert _covers_or_undetermined(est.parameters[name], truth[name])


def test_trailer_swap_is_located_and_split() -> None:
    disc, est, truth = _run(1, "trailer_swap", 0.3)
    assert disc.change is not None
    assert abs(disc.change.t_s - truth["t_swap_s"]) < truth["duration_s"] / 6  # one piece
    assert disc.adequacy is not None
    assert disc.adequacy.verdict == "does not explain"
    assert not est.identifiable
    assert "change" in est.verdict
    assert len(disc.split) == 2
    after = disc.split[1][2].parameters["L2"]
    assert abs(after.value - truth["L2_after"]) < 0.1 * truth["L2_after"]
    d = disc.to_dict()
    assert d["change"]["t_s"] == pytest.approx(disc.change.t_s)
    assert len(d["split"]) == 2


def test_gain_error_is_not_confidently_wrong() -> None:
    """A hitch angle 5 % high on a log of small angles: the gain cannot be told from L1, so L1
    spans both explanations instead of a narrow interval that excludes the truth."""
    disc, est, truth = _run(1, "hitch_gain", 0.05)
    assert _covers_or_undetermined(est.parameters["L1"], truth["L1"])
    assert any("gain" in n for n in disc.notes)


def test_misfit_makes_the_estimate_not_determined() -> None:
    """Adequacy alone (no search): a log the nominal model does not explain gets widened
    intervals and 'not determined', with the verdict saying why."""
    log = tractor_log(1, "hitch_backlash", 0.03)
    path, t, psi = _inputs(log)
    fit = PathTransientFit().fit(path, t, psi)
    judged = judge_path_fit(path, t, psi, [], fit, reason="test")
    assert judged.adequacy is not None
    assert judged.adequacy.verdict == "does not explain"
    assert judged.adequacy.channels[0].heldout_ratio is not None
    est = recommended(fit.result_, judged)
    assert not est.identifiable
    assert "does not explain" in est.verdict
    assert "sum_L1_L2" in est.derived
    assert not est.derived["sum_L1_L2"].identifiable
    for name in ("L1", "L2"):
        e, e0 = est.parameters[name], fit.result_.parameters[name]
        assert e.value == e0.value
        assert e.std > e0.std


def test_joint_model_recovers_a_gain_and_its_inverse() -> None:
    """The measurement model and its inverse agree: a reading scaled by 1.1 with an offset is
    undone by ``corrected`` from the joint fit's own estimates."""
    log = tractor_log(2)
    path, t, psi = _inputs(log)
    model = JointPathModel(path, t, 1.1 * psi + 0.02)
    fit = PathTransientFit().fit(path, t, psi)
    effects = (effect_by_key("sensor_scale(psi)"), effect_by_key("sensor_offset(psi)"))
    sol = model.fit(effects, np.concatenate([fit._x_raw[:2], [1.0, 0.0], fit.psi0_]))
    scale, off = sol.x[2], sol.x[3]
    assert abs(scale - 1.1) < 5 * math.sqrt(sol.cov[2, 2]) + 0.01
    assert abs(off - 0.02) < 5 * math.sqrt(sol.cov[3, 3]) + 0.002
    _, back = model.corrected(sol)
    assert np.sqrt(np.mean((back - psi[: back.size]) ** 2)) < 0.05


def test_joint_model_cache_hands_out_the_uncached_evaluation() -> None:
    """``JointPathModel.evaluate``'s cache returns, bit for bit, what integrating the path
    again returns (for the same effects and point; another set of effects is another entry),
    and what it hands out can be changed without changing the next answer."""
    log = tractor_log(2)
    path, t, psi = _inputs(log)
    model = JointPathModel(path, t, psi)
    fit = PathTransientFit().fit(path, t, psi)
    off = (effect_by_key("sensor_offset(psi)"),)
    x0 = np.concatenate([fit._x_raw[:2], fit.psi0_])
    x1 = np.concatenate([fit._x_raw[:2], [0.01], fit.psi0_])
    first = model.evaluate(x0, ())
    for a in first:
        a += 1.0  # the caller's copy
    again = model.evaluate(x0, ())
    shifted = model.evaluate(x1, off)
    for got, want in zip(again, model._evaluate(x0, ()), strict=True):
        np.testing.assert_array_equal(got, want)
    for got, want in zip(shifted, model._evaluate(x1, off), strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(shifted[0], again[0] + 0.01)


def test_pose_noise_is_not_taken_for_a_clock_offset() -> None:
    """A clean path (an actuator dead time only, which a measured path does not see) sampled at
    20 Hz with a noisy pose: shifting the modelled angle by a fraction of a sample must not
    pay by averaging the pose's noise (it did, by linear interpolation between samples: a
    clock offset of -21 ms took the held-out sum of squares from 714 to 488 and moved L1 from
    1.242 to 1.205, truth 1.25). Discovery stays quiet and the estimate covers the truth."""
    import indgen  # type: ignore[import-not-found]

    noise = {
        "cmd": {},
        "cmd_vel": {},
        "odom": {"v": 0.02, "omega": 0.005},
        "pose": {"x": 0.02, "y": 0.02, "yaw": 0.005},
        "hitch": {"angle": 0.005},
    }
    scn = indgen.Scenario(
        L1=1.25,
        L2=2.48,
        duration_s=60.0,
        command=indgen.Command(
            "random",
            M=0.12,
            freqs_hz=(0.03, 0.07, 0.12),
            phases=(0.0, 1.0, 2.0),
            weights=(0.4, 0.35, 0.25),
        ),
        speed=indgen.Speed(base=2.0),
        effects=indgen.Effects(actuator_delay_s=0.3),
        topics={g: indgen.TopicSpec(20.0, noise=n) for g, n in noise.items()},
    )
    gen = indgen.generate(scn, seed=1)
    pose = next(d for d in gen.topics.values() if d.group == "pose")
    hitch = next(d for d in gen.topics.values() if d.group == "hitch")
    t0 = int(min(pose.stamps_ns[0], hitch.stamps_ns[0]))
    path = DrivePath.from_pose(
        (pose.stamps_ns - t0) / 1e9,
        pose.fields["x"],
        pose.fields["y"],
        np.unwrap(pose.fields["yaw"]),
    )
    t, psi = (hitch.stamps_ns - t0) / 1e9, hitch.fields["angle"]
    fit = PathTransientFit().fit(path, t, psi)
    disc = discover_along_path(path, t, psi, [], fit)
    assert disc.accepted == ()
    assert disc.selection is not None
    gains = {tr.key: tr.heldout_gain for tr in disc.selection.tried}
    for key in ("clock_offset(hitch)", "backlash(psi)", "clock_drift(hitch)"):
        assert gains[key] < 0.05, gains
    est = recommended(fit.result_, disc)
    for name, truth in (("L1", 1.25), ("L2", 2.48)):
        e = est.parameters[name]
        assert abs(e.value - truth) < 0.03, e
        assert _covers_or_undetermined(e, truth), e


def test_link_lengths_unstable_across_pieces_are_widened() -> None:
    """A link length whose fits on pieces of the log disagree beyond their errors is widened
    (and not determined when that makes it wide), even when the residual is at the floor."""
    from calib.adequacy import PieceFit, piece_stability

    disc, est, _ = _run(2)
    assert not any(s.unstable for s in disc.stability.values())
    assert recommended(est, disc).parameters == est.parameters
    L1 = est.parameters["L1"].value
    sd = est.parameters["L1"].std
    pieces = [
        PieceFit(0.0, 1.0, {"L1": L1 - 0.3}, {"L1": sd}),
        PieceFit(1.0, 2.0, {"L1": L1}, {"L1": sd}),
        PieceFit(2.0, 3.0, {"L1": L1 + 0.3}, {"L1": sd}),
    ]
    disc.stability = piece_stability(pieces, ("L1",))
    assert disc.stability["L1"].unstable
    out = recommended(est, disc)
    e = out.parameters["L1"]
    assert e.std > 5 * sd
    assert not e.identifiable
    assert out.parameters["L2"] == est.parameters["L2"]
    assert out.verdict.startswith("Not determined")
