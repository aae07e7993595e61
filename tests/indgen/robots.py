"""One entry point for the three robots' kind-bearing logs: ``generate_log`` draws nothing but
from ``seed`` and attaches the effect size of the kind (``robotlog.effect_size``) to the truth.

``truth["effect_size"]``: {channel: RMS(with - without) / noise std}; ``truth["max_effect_size"]``
the largest (0 for a clean log, computed the same way against a regenerated clean twin).

Refit-aware effect sizes (``refit.refit_effect``: the part of the kind's effect on the modelled
channels that a refit of the robot's own parameters cannot absorb, in noise units):
``truth["refit_effect_size"]`` (in-sample) and ``truth["heldout_effect_size"]`` (parameters
fitted on alternate time blocks, evaluated on the others), each the largest over the modelled
channels; per channel in ``truth["refit_effect_channels"]`` / ``truth["heldout_effect_channels"]``;
``truth["refit"]`` the refit's parameter shifts and cost. ``refit=False`` skips them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .arm import arm_log
from .diffdrive import diff_drive_log
from .kinds import KINDS
from .refit import refit_effect
from .robotlog import RobotLog, effect_size
from .tractor_kinds import tractor_log

__all__ = ["GENERATORS", "generate_log"]

GENERATORS: dict[str, Callable[..., RobotLog]] = {
    "tractor_trailer": tractor_log,
    "diff_drive": diff_drive_log,
    "arm": arm_log,
}


def generate_log(
    robot: str,
    seed: int,
    kind: str | None = None,
    magnitude: float = 0.0,
    *,
    refit: bool = True,
    **kw: Any,
) -> RobotLog:
    """A log of ``robot`` with ``kind`` at ``magnitude`` (None: clean), effect sizes attached
    (the refit-aware ones unless ``refit`` is False)."""
    if kind is not None and KINDS[kind].robot != robot:
        raise ValueError(f"kind {kind!r} is a {KINDS[kind].robot} kind, not {robot}")
    gen = GENERATORS[robot]
    log = gen(seed, kind, magnitude, **kw)
    clean = gen(seed, None, 0.0, **kw)
    es = effect_size(log, clean)
    log.truth["effect_size"] = es
    log.truth["max_effect_size"] = max(es.values(), default=0.0)
    if refit:
        rf = refit_effect(gen, seed, log, clean, **kw)
        log.truth["refit_effect_channels"] = rf["refit"]
        log.truth["heldout_effect_channels"] = rf["heldout"]
        log.truth["refit_effect_size"] = max(rf["refit"].values(), default=0.0)
        log.truth["heldout_effect_size"] = max(rf["heldout"].values(), default=0.0)
        log.truth["refit"] = {k: rf[k] for k in ("beta", "iterations", "generated", "seconds")}
    if kind is not None:
        d = KINDS[kind]
        log.truth["kind_param"] = {d.param: magnitude}
    return log
