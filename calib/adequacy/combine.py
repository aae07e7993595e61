"""Adequacy over several runs pooled into one estimate: the pooled model explains the runs only
if it explains each; the runs it does not explain are named."""

from __future__ import annotations

from collections.abc import Sequence

from calib.adequacy.verdict import EXPLAINS, NOT_EXPLAINED, Adequacy, not_assessed

__all__ = ["combine_runs"]


def combine_runs(runs: Sequence[tuple[str, Adequacy | None]], model: str) -> Adequacy:
    """One verdict for ``runs`` (name, that run's adequacy): "does not explain" when any run's
    model does not explain it (its channels and locations kept, the run named), "explains" when
    every run was judged and explained, else not assessed."""
    judged = [(name, a) for name, a in runs if a is not None and a.channels]
    if not judged:
        return not_assessed(model, "no run's model could be judged")
    bad = [(name, a) for name, a in judged if not a.explains]
    unjudged = len(runs) - len(judged)
    notes = [f"{unjudged} of {len(runs)} runs not assessed"] if unjudged else []
    if not bad:
        if unjudged:
            return not_assessed(model, notes[0])
        return Adequacy(
            EXPLAINS,
            model,
            tuple(c for _, a in judged for c in a.channels),
            notes=(f"explains each of the {len(judged)} runs",),
        )
    notes.insert(0, "does not explain run(s) " + ", ".join(name for name, _ in bad))
    return Adequacy(
        NOT_EXPLAINED,
        model,
        tuple(c for _, a in bad for c in a.channels),
        tuple(loc for _, a in bad for loc in a.located),
        tuple(ch for _, a in bad for ch in a.changes),
        "; ".join(f"{name}: {a.unexplained}" for name, a in bad if a.unexplained) or None,
        notes=tuple(notes),
    )
