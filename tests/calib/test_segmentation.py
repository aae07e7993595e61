"""Segmentation by command type, checked against simulated command sequences with known truth."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from calib.tractor_trailer.results import CommandType as C
from calib.tractor_trailer.results import Segment
from calib.tractor_trailer.segmentation import segment_command
from calib.tractor_trailer.sim.commands import CommandSequence
from calib.tractor_trailer.sim.commands import CommandSpec as S
from calib.tractor_trailer.sim.tractor_trailer import TractorTrailerSim, simulate_tractor_trailer

# Mixed command with known boundaries. Harmonic -> curve is a smooth join (sin ends near 0
# with slope M w, tanh starts at 0 with slope M w); step -> harmonic(phase pi/2) joins with
# equal value and slope. The others join with jumps or kinks.
MIXED = CommandSequence(
    [
        S(C.HARMONIC, 63, 0.2, 0.1),
        S(C.CURVE, 63, 0.2, 0.1),
        S(C.LINEAR, 63, 0.1, 0.1),
        S(C.STEP, 30, 0.15, offset=-0.05, step_at_s=15),
        S(C.HARMONIC, 40, 0.1, 0.2, phase=np.pi / 2),
        S(C.CONSTANT, 20, 0.05),
        S(C.CURVE, 40, -0.15, 0.2),
        S(C.LINEAR, 50, 0.2, 0.05, offset=0.1),
    ]
)


def _labels_truth(truth: list[Segment], t: np.ndarray) -> np.ndarray:
    lab = np.empty(t.size, dtype=object)
    for s in truth:
        lab[(t >= s.start_s) & (t < s.end_s)] = s.command_type
    lab[t >= truth[-1].start_s] = truth[-1].command_type
    return lab


def _labels_found(found: list[Segment], n: int) -> np.ndarray:
    lab = np.empty(n, dtype=object)
    for s in found:
        lab[s.start_index : s.end_index] = s.command_type
    return lab


def _boundary_errors(truth: list[Segment], found: list[Segment]) -> np.ndarray:
    fb = np.array([s.start_s for s in found[1:]])
    return np.array([np.min(np.abs(fb - s.start_s)) for s in truth[1:]])


def _check_cover(found: list[Segment], t: np.ndarray) -> None:
    assert found[0].start_index == 0
    assert found[-1].end_index == t.size
    for a, b in itertools.pairwise(found):
        assert a.end_index == b.start_index
        assert a.end_s == pytest.approx(b.start_s)
    for s in found:
        assert s.start_s == pytest.approx(t[s.start_index] - t[0])


@pytest.mark.parametrize(
    ("noise", "quantum"),
    [(0.0, 0.0), (1e-4, 0.0), (1e-3, 0.0), (0.0, 1e-3)],
    ids=["exact", "noise1e-4", "noise1e-3", "quantised1e-3"],
)
def test_mixed_log_labels_and_boundaries(noise, quantum):
    t = np.arange(0.0, MIXED.duration_s, 0.01)
    y = MIXED(t)
    if noise:
        y = y + np.random.default_rng(1).normal(0.0, noise, t.size)
    if quantum:
        y = np.round(y / quantum) * quantum
    found = segment_command(t, y)
    truth = MIXED.segments()
    _check_cover(found, t)
    acc = np.mean(_labels_truth(truth, t) == _labels_found(found, t.size))
    assert acc >= 0.95
    assert len(found) == len(truth)
    errors = _boundary_errors(truth, found)
    assert np.all(errors <= 1.0), errors
    if noise == 0 and quantum == 0:  # exact input: every boundary on its sample
        assert np.all(errors <= 0.011), errors


def test_coarsely_quantised_command():
    """Quantum 0.01 1/m (5 % of the amplitude): labels still right; the two smooth joins
    (harmonic -> curve at 63 s, step -> cosine at 219 s) can only be placed to within the
    time the two templates take to differ by a quantum, about 1.6-3 s."""
    t = np.arange(0.0, MIXED.duration_s, 0.01)
    y = np.round(MIXED(t) / 0.01) * 0.01
    found = segment_command(t, y)
    truth = MIXED.segments()
    acc = np.mean(_labels_truth(truth, t) == _labels_found(found, t.size))
    assert acc >= 0.95
    assert len(found) == len(truth)
    errors = _boundary_errors(truth, found)
    smooth = np.isin([s.start_s for s in truth[1:]], [63.0, 219.0])
    assert np.all(errors[~smooth] <= 1.0), errors
    assert np.all(errors[smooth] <= 3.0), errors


def test_fitted_parameters_match_the_specs():
    t = np.arange(0.0, MIXED.duration_s, 0.01)
    found = segment_command(t, MIXED(t))
    h, c, lin, step = found[0], found[1], found[2], found[3]
    assert h.parameters["M"] == pytest.approx(0.2, rel=1e-4)
    assert h.parameters["omega"] == pytest.approx(0.1, rel=1e-4)
    assert abs(h.parameters["phi"]) < 1e-3
    assert c.parameters["M"] == pytest.approx(0.2, rel=1e-4)
    assert c.parameters["omega"] == pytest.approx(0.1, rel=1e-4)
    assert abs(c.parameters["t0"]) < 0.02
    assert lin.parameters["a"] == pytest.approx(0.1 * 0.1 / np.pi, rel=1e-6)
    assert lin.parameters["b"] == pytest.approx(-0.1, abs=1e-6)
    assert step.parameters["c1"] == pytest.approx(-0.05, abs=1e-9)
    assert step.parameters["c2"] == pytest.approx(0.10, abs=1e-9)
    assert step.parameters["t_step"] == pytest.approx(15.0, abs=0.011)
    assert all(s.parameters["rms"] < 1e-6 for s in found)


def test_step_rule_constant_then_step_is_one_step_segment():
    """A jump between two constant stretches: one step segment spanning both."""
    seq = CommandSequence(
        [
            S(C.CONSTANT, 20, 0.0),
            S(C.STEP, 20, 0.1, step_at_s=10),  # 0 then 0.1 from t = 30 s
            S(C.HARMONIC, 40, 0.1, 0.2, phase=1.0),
        ]
    )
    t = np.arange(0.0, seq.duration_s, 0.01)
    found = segment_command(t, seq(t))
    assert [s.command_type for s in found] == [C.STEP, C.HARMONIC]
    assert found[0].end_s == pytest.approx(40.0, abs=0.011)
    assert found[0].parameters["t_step"] == pytest.approx(30.0, abs=0.011)
    assert found[0].parameters["c1"] == pytest.approx(0.0, abs=1e-12)
    assert found[0].parameters["c2"] == pytest.approx(0.1, abs=1e-12)


def test_step_rule_pairs_levels_with_the_jump_in_the_middle():
    """Levels 0.05 (30 s) | -0.1 (15 s) | 0.2 (15 s): one step is possible, and it is made of
    the two levels whose jump is nearest its middle; the level left over is a constant."""
    seq = CommandSequence(
        [S(C.CONSTANT, 30, 0.05), S(C.STEP, 30, 0.3, offset=-0.1, step_at_s=15)]
    )  # the simulator's "constant then step": jumps at 30 s and 45 s
    t = np.arange(0.0, seq.duration_s, 0.01)
    found = segment_command(t, seq(t))
    assert [s.command_type for s in found] == [C.CONSTANT, C.STEP]
    assert found[1].start_s == pytest.approx(30.0, abs=0.011)
    assert found[1].parameters["t_step"] == pytest.approx(15.0, abs=0.011)
    assert found[1].parameters["c1"] == pytest.approx(-0.1, abs=1e-12)
    assert found[1].parameters["c2"] == pytest.approx(0.2, abs=1e-12)
    # four levels: two steps; the first pairs levels 1-2, the second levels 3-4
    seq4 = CommandSequence([S(C.CONSTANT, d, c) for d, c in [(10, 0), (20, 1), (5, 0), (9, 1)]])
    t4 = np.arange(0.0, seq4.duration_s, 0.01)
    found4 = segment_command(t4, seq4(t4) * 0.1)
    assert [s.command_type for s in found4] == [C.STEP, C.STEP]
    assert found4[1].start_s == pytest.approx(30.0, abs=0.011)
    constant = segment_command(t, np.full(t.size, 0.05))
    assert [s.command_type for s in constant] == [C.CONSTANT]


def test_simulated_log_with_gaps_and_nan():
    """The command as the simulator logs it, with dropped rows and a NaN sample."""
    seq = CommandSequence(
        [S(C.LINEAR, 63, 0.2, 0.1), S(C.HARMONIC, 63, 0.2, 0.1), S(C.CURVE, 63, -0.1, 0.1)]
    )
    run = simulate_tractor_trailer(TractorTrailerSim(commands=seq))
    cmd = run.frames["cmd"]
    t = (cmd["t_ns"].to_numpy() - cmd["t_ns"][0]) / 1e9
    y = cmd["kappa_cmd"].to_numpy().copy()
    keep = np.ones(t.size, dtype=bool)
    keep[5000:5300] = False  # a 3 s dropout inside the harmonic
    y[9000] = np.nan
    t, y = t[keep], y[keep]
    found = segment_command(t, y)
    _check_cover(found, t)
    truth = run.segments
    assert [s.command_type for s in found] == [s.command_type for s in truth]
    assert np.all(_boundary_errors(truth, found) <= 1.0)


@pytest.mark.slow
def test_hour_long_log():
    """360k samples (1 h at 100 Hz): runs (speed is measured in bench/) and stays accurate."""
    t = np.arange(0.0, 3600.0, 0.01)
    reps = int(np.ceil(3600.0 / MIXED.duration_s))
    seq = CommandSequence(list(MIXED.specs) * reps)
    found = segment_command(t, seq(t))
    acc = np.mean(_labels_truth(seq.segments(), t) == _labels_found(found, t.size))
    assert acc >= 0.95


def test_short_and_bad_inputs():
    assert segment_command(np.array([]), np.array([])) == []
    short = segment_command(np.arange(3.0), np.zeros(3))
    assert [(s.start_index, s.end_index) for s in short] == [(0, 3)]
    nan = segment_command(np.arange(100.0), np.full(100, np.nan))
    assert [s.command_type for s in nan] == [C.OTHER]
    with pytest.raises(ValueError, match="equal length"):
        segment_command(np.arange(5.0), np.zeros(4))
    with pytest.raises(ValueError, match="strictly increasing"):
        segment_command(np.array([0.0, 1.0, 1.0, 2.0]), np.zeros(4))


def test_segments_are_json_safe():
    t = np.arange(0.0, 100.0, 0.1)
    found = segment_command(t, 0.1 * np.sin(0.2 * t))
    d = found[0].to_dict()
    assert d["command_type"] == "harmonic"
    assert set(d["parameters"]) == {"M", "omega", "phi", "c", "rms"}
