"""Segmentation study: label accuracy, boundary error and speed on random mixed-command logs.

Usage: python bench/segmentation_study.py [--logs N] [--minutes M] [--noise SIGMA ...]
       [--quantum Q] [--continuous]

For each noise level, N random command sequences (``random_sequence``) of M minutes at 100 Hz
are segmented; printed: fraction of samples with the true label, the share of true boundaries
found within 1 s, the median and 95th percentile boundary error (s), and the time per log
relative to a baseline measured in the same run (one numpy FFT pass over the same samples).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from calib.tractor_trailer.results import CommandType, Segment
from calib.tractor_trailer.segmentation import segment_command
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec, command_value

AMBIGUOUS_BEFORE_CONSTANT = (CommandType.CONSTANT, CommandType.CURVE, CommandType.STEP)
CONTINUOUS_NOT_BEFORE_STEP = (CommandType.STEP, CommandType.CURVE)
KINDS = (
    CommandType.HARMONIC,
    CommandType.CURVE,
    CommandType.LINEAR,
    CommandType.CONSTANT,
    CommandType.STEP,
)


def random_sequence(
    rng: np.random.Generator, duration_s: float, continuous: bool = False
) -> CommandSequence:
    """Random mix of the five command types, 30-90 s each, amplitudes 0.05-0.25 1/m.

    Left out, because the command alone cannot tell where the simulator put the boundary:
    two constants in a row, a constant next to a step (which of the jumps between the levels
    is the step's is a guess, see calib.tractor_trailer.segmentation.step_rule), and a constant
    after a curve (it may sit at the tanh's saturation level). Steps jump at 40-60 % of
    their length; steps may follow steps (their levels pair up unambiguously).

    ``continuous``: each segment starts at the value where the previous one ended (offsets
    chosen so), so boundaries are kinks or smooth joins, never jumps; then no step follows a
    step or a curve either (its first level would continue the previous level or the tanh's
    saturated tail).
    """
    specs: list[CommandSpec] = []
    total = 0.0
    prev: CommandType | None = None
    while total < duration_s:
        choices = [
            k
            for k in KINDS
            if not (
                (k is CommandType.CONSTANT and prev in AMBIGUOUS_BEFORE_CONSTANT)
                or (k is CommandType.STEP and prev is CommandType.CONSTANT)
                or (continuous and k is CommandType.STEP and prev in CONTINUOUS_NOT_BEFORE_STEP)
            )
        ]
        kind = choices[rng.integers(len(choices))]
        dur = float(rng.uniform(30, 90))
        amp = float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.25))
        rate = (
            float(rng.uniform(0.1, 0.3))
            if kind is CommandType.HARMONIC
            else float(rng.uniform(0.05, 0.3))
        )
        spec = CommandSpec(
            kind,
            dur,
            amplitude=amp,
            rate=rate,
            phase=float(rng.uniform(-np.pi, np.pi)),
            offset=float(rng.uniform(-0.05, 0.05)),
            step_at_s=float(rng.uniform(0.4, 0.6) * dur),
        )
        if continuous and specs:
            end = float(command_value(specs[-1], specs[-1].duration_s))
            start = float(command_value(spec, 0.0)) - spec.offset
            spec = replace(spec, offset=end - start)
        specs.append(spec)
        total += dur
        prev = kind
    return CommandSequence(specs)


def score(truth: list[Segment], found: list[Segment], t: np.ndarray) -> tuple[float, np.ndarray]:
    """Fraction of samples labelled right; error (s) from each true boundary to the nearest."""
    edges = np.array([s.start_s for s in truth[1:]])
    lt = np.empty(t.size, dtype=object)
    for s in truth:
        lt[(t >= s.start_s) & (t < s.end_s)] = s.command_type
    lt[t >= truth[-1].start_s] = truth[-1].command_type
    lp = np.empty(t.size, dtype=object)
    for s in found:
        lp[s.start_index : s.end_index] = s.command_type
    fb = np.array([s.start_s for s in found[1:]])
    err = np.array([np.min(np.abs(fb - e)) if fb.size else np.inf for e in edges])
    return float(np.mean(lt == lp)), err


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=10)
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--noise", type=float, nargs="*", default=[0.0, 1e-4, 1e-3])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quantum", type=float, default=0.0, help="quantise the command (1/m)")
    ap.add_argument("--continuous", action="store_true", help="no jumps between segments")
    args = ap.parse_args()
    for sigma in args.noise:
        rng = np.random.default_rng(args.seed)
        acc, errs, ratios = [], [], []
        for _ in range(args.logs):
            seq = random_sequence(rng, args.minutes * 60, args.continuous)
            t = np.arange(0, seq.duration_s, 0.01)
            y = seq(t) + (rng.normal(0, sigma, t.size) if sigma else 0.0)
            if args.quantum:
                y = np.round(y / args.quantum) * args.quantum
            t0 = time.perf_counter()
            np.fft.rfft(y)
            base = time.perf_counter() - t0
            t0 = time.perf_counter()
            found = segment_command(t, y)
            el = time.perf_counter() - t0
            a, e = score(seq.segments(), found, t)
            acc.append(a)
            errs.append(e)
            ratios.append((el, el / base))
        e = np.concatenate(errs)
        el = np.array(ratios)
        print(
            f"noise {sigma:g}: accuracy mean {np.mean(acc):.4f} min {np.min(acc):.4f}; "
            f"boundaries within 1 s {np.mean(e <= 1.0):.3f}, error median {np.median(e):.3f} s "
            f"p95 {np.percentile(e, 95):.2f} s; time per log {np.mean(el[:, 0]):.2f} s "
            f"({np.mean(el[:, 1]):.0f}x one FFT of the log)"
        )


if __name__ == "__main__":
    main()
