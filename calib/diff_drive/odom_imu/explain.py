"""After selection: the residual the selected gain law leaves modelled from the log's own signals
(:func:`calib.discovery.describe`, kept by the engine's rules), and the gain law of the model
that ends discovery re-estimated and re-reported (:mod:`calib.diff_drive.odom_imu.law`), for the
final model and for each confound's alternative."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.odom_imu.described import described_hook, entry, library, space
from calib.diff_drive.odom_imu.fitter import GainFitter, GainPayload
from calib.diff_drive.odom_imu.law import GainLaw, gain_law
from calib.diff_drive.odom_imu.windows import FOLD_S, WINDOW_S
from calib.discovery import Description, ModelFit, Selection, describe

__all__ = ["Explained", "explain"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Explained:
    """The model discovery ends with (``final``: the selection's, with the described effect when
    it was accepted), the description tried (accepted or not), the final law and each
    alternative's (label -> law)."""

    final: ModelFit
    description: Description | None
    law: GainLaw | None
    alternatives: dict[str, GainLaw]


def _describe(
    fitter: GainFitter, current: ModelFit, t: Array, v: Array, omega: Array, explained: bool
) -> Description | None:
    pay: GainPayload = current.payload
    ent = entry(t, fitter.w, fitter.use, fitter.sigma)
    sp = space(pay.residual, fitter.use, fitter.folds, ent, pay.jac)
    block = max(4, round(FOLD_S / WINDOW_S))
    try:
        return describe(
            fitter,
            current,
            sp,
            library(t, v, omega),
            block=block,
            hook=described_hook(t, fitter.w),
            explained=explained,
        )
    except (ValueError, np.linalg.LinAlgError):
        return None


def explain(
    fitter: GainFitter,
    sel: Selection,
    t: Array,
    v: Array,
    omega: Array,
    constant_explains: bool,
) -> Explained:
    """Describe what ``sel``'s final model leaves and re-report the law (module docstring);
    ``t``, ``v``, ``omega``: the samples the windows were cut from; ``constant_explains``: the
    constant-gain model already explains the log (a description must then bring more)."""
    law0 = gain_law(fitter, sel.final) if sel.final.effects else None
    explained = law0.explains if law0 is not None else constant_explains
    d = _describe(fitter, sel.final, t, v, omega, explained)
    final = d.fit if d is not None and d.accepted else sel.final
    law = law0 if final is sel.final else gain_law(fitter, final)
    alts = {c.alternative: gain_law(fitter, c.alternative_fit) for c in sel.confounds}
    return Explained(final, d, law, alts)
