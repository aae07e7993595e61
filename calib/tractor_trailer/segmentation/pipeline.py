"""Split a curvature command into segments and label each with its template type.

Pipeline (``segment_command``):

1. **Decimate** the command onto a uniform grid of at most 10 Hz by picking the nearest sample
   (no averaging, so jumps stay sharp). The noise level sigma is estimated from second
   differences (robust MAD and a trimmed RMS) with a floor of 1e-3 of the command's scale and,
   for a quantised command (its changes are multiples of a step q), of q / sqrt(12).
2. **Change points.** Value jumps are found on the first differences (larger than
   8 sigma sqrt(2), 2 % of the scale and 2.5 q, beyond what the local slope explains), placed on
   the exact sample of the full-rate signal. Between jumps, binary segmentation splits each
   stretch where two straight lines fit best (so breaks land on slope changes), until a piece
   is fitted by one template to within the noise (reduced chi^2 <= 1 + 4 sqrt(2 / n)) or is
   shorter than 2 s.
3. **Merge by BIC.** Each piece is fitted with every template (see Templates below);
   its cost is BIC = RSS / sigma^2 + (k + 1) ln N (k template parameters, + 1 for the
   boundary, N samples). Adjacent pieces not separated by a jump are merged, greediest first,
   while the merged segment's best template has a lower BIC than the two apart. A template
   segment is never merged into "other".
4. **Dissolve and refine.** A segment of at most 30 s between two others, not separated by
   jumps, usually straddles a smooth join (a harmonic ending at 0 followed by a tanh from 0):
   it is handed to its neighbours when that lowers the BIC. Then each boundary that is not a
   jump is refined: both neighbours' templates are fitted away from it (margin: a quarter of
   the window), extrapolated over a window of +-8 s, and the boundary moves to where the
   summed squared residuals are least, if that lowers the BIC (up to 4 passes, relabelling
   both sides in between). Merging (3.) and refining are then run once more.
5. **Step rule.** A jump between two constant levels is held by a ``step`` segment made of
   both levels (template: levels ``c1``, ``c2`` and the local jump time ``t_step``). Where
   several levels follow each other across jumps, they are grouped into as many steps as
   possible, and among those groupings the one whose jumps lie nearest the middle of their
   steps wins (the simulator's step has its jump in the middle); a level left over is a
   ``constant``. E.g. levels of 30 s, 15 s, 15 s give constant + step (jump in the middle);
   two levels give one step.
6. Segments shorter than ``min_len_s`` are merged into the neighbour that fits best; every
   segment is finally labelled by the lowest BIC over the templates, and its parameters
   (segment-local time, s) go into ``Segment.parameters`` with ``rms`` (1/m), the fit's
   residual RMS.

Templates: see ``calib.tractor_trailer.segmentation.templates``.
"""

from __future__ import annotations

import numpy as np

from calib.tractor_trailer.results import CommandType, Segment
from calib.tractor_trailer.segmentation.change_points import binseg, jumps, quantum
from calib.tractor_trailer.segmentation.merging import absorb_short, merge
from calib.tractor_trailer.segmentation.preparation import (
    clean_inputs,
    command_scale,
    decimate,
    noise_sigma,
)
from calib.tractor_trailer.segmentation.refinement import dissolve_short, refine
from calib.tractor_trailer.segmentation.scoring import Piece, Scorer
from calib.tractor_trailer.segmentation.settings import SegmentationSettings
from calib.tractor_trailer.segmentation.step_rule import step_rule
from calib.tractor_trailer.segmentation.templates import TemplateFit

__all__ = ["segment_command"]


def segment_command(
    t_s: np.ndarray,
    kappa_cmd: np.ndarray,
    *,
    min_len_s: float = 5.0,
    settings: SegmentationSettings | None = None,
) -> list[Segment]:
    """Segment a curvature command by template type (see the module docstring).

    Args:
        t_s: sample times (s), strictly increasing (gaps allowed).
        kappa_cmd: curvature command (1/m) at those times; NaN samples are bridged.
        min_len_s: shortest segment (s) reported.
        settings: tuning; None for the defaults.

    Returns:
        Segments covering all samples in order; ``start_index``/``end_index`` index ``t_s``
        (end exclusive), ``start_s``/``end_s`` are times of the first sample of the segment
        and of the next one (or the last sample), relative to ``t_s[0]``.

    Raises:
        ValueError: mismatched shapes or times not strictly increasing.
    """
    cfg = settings or SegmentationSettings()
    t, y = clean_inputs(t_s, kappa_cmd)
    n = t.size
    if n == 0:
        return []
    if n < 8 or not np.any(np.isfinite(y)):
        kind = CommandType.OTHER if not np.any(np.isfinite(y)) else CommandType.CONSTANT
        return [Segment(0.0, float(t[-1] - t[0]), kind, 0, n, {})]
    td, yd, picked = decimate(t, y, cfg.max_rate_hz)
    dt = float(td[1] - td[0]) if td.size > 1 else 1.0
    scale = command_scale(yd)
    q = quantum(yd, scale)
    floor = max(cfg.sigma_floor_frac * scale, q / np.sqrt(12), 1e-12)
    sigma = noise_sigma(yd, floor)
    step = max(1, round(1.0 / (cfg.merge_rate_hz * dt)))
    sc = Scorer(td, yd, step, sigma)
    edges = [0, *jumps(yd, sigma, scale, q, cfg).tolist(), td.size]
    min_piece = max(2, round(cfg.min_piece_s / dt))
    segs: list[Piece] = []
    for k in range(len(edges) - 1):
        pieces = binseg(td, yd, edges[k], edges[k + 1], sc, min_piece)
        pieces[0].jump_left = k > 0
        segs += pieces
    segs = merge(segs, sc)
    win = max(2, round(cfg.refine_window_s / dt))
    segs = dissolve_short(segs, sc, round(cfg.dissolve_max_s / dt), win)
    refine(segs, sc, win)
    segs = merge(segs, sc)  # refined boundaries can make neighbours one template again
    refine(segs, sc, win)
    segs = absorb_short(segs, sc, max(1, round(min_len_s / dt)))
    fits: _FitCache = {}
    _final_fits(segs, t, y, picked, sc, fits)  # labels at the full rate decide the step rule
    segs = step_rule(segs, sc)
    return _to_segments(segs, t, y, picked, sc, fits)


def _full_index(seg: Piece, y: np.ndarray, picked: np.ndarray) -> int:
    """Index into the full-rate samples where ``seg`` starts (``picked``: decimated -> full)."""
    if seg.a == 0:
        return 0
    if seg.jump_left:  # the exact sample of the jump, between the decimated neighbours
        lo, hi = int(picked[seg.a - 1]), int(picked[seg.a])
        d = np.abs(np.diff(y[lo : hi + 1]))
        return lo + 1 + int(np.argmax(d)) if d.size else hi
    return int(picked[seg.a])


#: (start, end, stride, weight) -> best full-rate template: the segments the step rule leaves
#: alone are not fitted twice.
_FitCache = dict[tuple[int, int, int, float], TemplateFit]


def _final_fits(
    segs: list[Piece],
    t: np.ndarray,
    y: np.ndarray,
    picked: np.ndarray,
    sc: Scorer,
    cache: _FitCache,
) -> list[tuple[int, int, TemplateFit]]:
    """Full-rate [start, end) indices and the best template of each segment."""
    starts = [_full_index(s, y, picked) for s in segs] + [t.size]
    out = []
    for k, s in enumerate(segs):
        i0, i1 = starts[k], starts[k + 1]
        if i1 <= i0:
            continue
        st = max(1, (i1 - i0) // 4000)
        weight = st * (s.b - s.a) / max(i1 - i0, 1) / sc.step
        key = (i0, i1, st, weight)
        if key not in cache:
            cache[key] = sc.best_xy(t[i0:i1:st] - t[i0], y[i0:i1:st], weight)[0]
        fit = cache[key]
        s.fit = fit
        out.append((i0, i1, fit))
    return out


def _to_segments(
    segs: list[Piece],
    t: np.ndarray,
    y: np.ndarray,
    picked: np.ndarray,
    sc: Scorer,
    cache: _FitCache,
) -> list[Segment]:
    out: list[Segment] = []
    for i0, i1, fit in _final_fits(segs, t, y, picked, sc, cache):
        t_loc = t[i0:i1] - t[i0]
        rms = float(np.sqrt(np.mean((y[i0:i1] - fit(t_loc)) ** 2)))
        end = t[i1] if i1 < t.size else t[-1]
        params = {**fit.params, "rms": rms}
        out.append(Segment(float(t[i0] - t[0]), float(end - t[0]), fit.kind, i0, i1, params))
    return out
