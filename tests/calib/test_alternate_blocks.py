"""The shared held-out split, ``calib.stats.alternate_blocks``, used by the diff drive's
discovery and by the test-only Ackermann car's fitter: deterministic facts of the split."""

from __future__ import annotations

import numpy as np
import pytest

from calib.stats import alternate_blocks


def test_blocks_alternate_and_cover_every_sample_once() -> None:
    even, odd = alternate_blocks(10, 3)
    assert even.tolist() == [0, 1, 2, 6, 7, 8]
    assert odd.tolist() == [3, 4, 5, 9]
    assert np.union1d(even, odd).tolist() == list(range(10))


def test_no_samples_and_bad_blocks() -> None:
    even, odd = alternate_blocks(0, 5)
    assert even.size == odd.size == 0
    with pytest.raises(ValueError, match="block = 0"):
        alternate_blocks(5, 0)


def test_the_diff_drive_uses_the_shared_split() -> None:
    from calib.diff_drive import discovery

    n = 4 * discovery.CV_BLOCK + 3
    got = discovery._folds(n)
    want = alternate_blocks(n, discovery.CV_BLOCK)
    assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))
