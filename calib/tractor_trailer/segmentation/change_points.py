"""Change points of the command: value jumps, and binary segmentation between them."""

from __future__ import annotations

import numpy as np

from calib.tractor_trailer.segmentation.scoring import Piece, Scorer, score
from calib.tractor_trailer.segmentation.settings import SegmentationSettings

__all__ = ["binseg", "jumps", "line_rss_splits", "quantum"]


def quantum(y: np.ndarray, scale: float) -> float:
    """Quantisation step (1/m) of the command, 0 when its changes are not on a lattice."""
    d = np.abs(np.diff(y))
    nz = d[d > 1e-9 * max(scale, 1e-300)]
    if nz.size < 10:
        return 0.0
    q = float(np.percentile(nz, 5))
    r = nz / q
    on_lattice = np.mean(np.abs(r - np.round(r)) < 0.02)
    return q if on_lattice >= 0.95 else 0.0


def jumps(
    y: np.ndarray, sigma: float, scale: float, quantum: float, cfg: SegmentationSettings
) -> np.ndarray:
    """Decimated indices i where a new level starts (jump between i - 1 and i)."""
    d = np.diff(y)
    if d.size < 3:
        return np.array([], dtype=int)
    pad = np.pad(d, 2, mode="edge")
    neigh = np.stack([pad[0:-4], pad[1:-3], pad[3:-1], pad[4:]])
    pred = np.median(neigh, axis=0)
    thr = max(cfg.jump_sigmas * sigma * np.sqrt(2), cfg.jump_frac * scale, 2.5 * quantum)
    excess = np.abs(d - pred)
    cand = np.flatnonzero(excess > thr)
    # one jump per cluster of neighbouring candidates: keep the largest
    keep: list[int] = []
    for i in cand:
        if keep and i - keep[-1] <= 1:
            if excess[i] > excess[keep[-1]]:
                keep[-1] = int(i)
        else:
            keep.append(int(i))
    return np.asarray(keep, dtype=int) + 1


def line_rss_splits(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """RSS of two-line fits split before each index j (1..n-1), and of one line."""
    t = t - t.mean()
    cols = np.stack([np.ones_like(t), t, t * t, y, t * y, y * y])
    cs = np.cumsum(cols, axis=1)
    tot = cs[:, -1]

    def rss(s: np.ndarray) -> np.ndarray:
        n, st, stt, sy, sty, syy = s
        det = n * stt - st * st
        with np.errstate(divide="ignore", invalid="ignore"):
            fit = np.where(
                det > 0,
                (stt * sy * sy - 2 * st * sy * sty + n * sty * sty) / det,
                np.where(n > 0, sy * sy / np.maximum(n, 1), 0.0),
            )
        return np.maximum(syy - fit, 0.0)

    left = cs[:, :-1]
    right = tot[:, None] - left
    return rss(left) + rss(right), float(rss(tot[:, None])[0])


def binseg(t: np.ndarray, y: np.ndarray, a: int, b: int, sc: Scorer, min_piece: int) -> list[Piece]:
    """Pieces of [a, b) from binary segmentation: split where two lines fit best, until a
    piece is fitted by one template to within the noise (or is too short to split)."""
    pieces: list[Piece] = []
    stack = [(a, b)]
    while stack:
        lo, hi = stack.pop()
        seg = Piece(lo, hi, False)
        score(seg, sc, allow_other=False)
        n_eff = len(range(lo, hi, sc.thin(lo, hi)))
        chi2_red = seg.template.rss * sc.weight(lo, hi) / sc.sigma**2 / n_eff
        if hi - lo < 2 * min_piece or chi2_red <= 1.0 + 4.0 * np.sqrt(2.0 / n_eff):
            pieces.append(seg)
            continue
        split, _ = line_rss_splits(t[lo:hi], y[lo:hi])
        j = np.arange(1, hi - lo)
        ok = (j >= min_piece) & (j <= hi - lo - min_piece)
        k = int(j[ok][np.argmin(split[ok])])
        stack += [(lo + k, hi), (lo, lo + k)]
    return sorted(pieces, key=lambda p: p.a)
