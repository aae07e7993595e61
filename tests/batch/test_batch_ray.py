"""Ray and the local process pool give identical outputs on the same archive (a local Ray
instance with 2 CPUs)."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl
import pytest
from batch_archive import FAST, small_archive

from logtools.batch.engines import Engine
from logtools.batch.runner import read_records, run_batch

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def ray_local():  # type: ignore[no-untyped-def]
    ray = pytest.importorskip("ray", reason="ray is not installed (pip install 'logcal[ray]')")
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    except Exception as err:  # no shared memory, no ports, ...
        pytest.skip(f"a local Ray instance cannot start here: {type(err).__name__}: {err}")
    yield ray
    ray.shutdown()


def test_ray_and_local_pool_agree(ray_local: object, tmp_path: Path) -> None:
    archive = small_archive(tmp_path / "archive", n=4)
    local, remote = tmp_path / "local", tmp_path / "ray"
    a = run_batch(archive, local, options=FAST, engine=Engine.LOCAL, workers=2)
    b = run_batch(archive, remote, options=FAST, engine=Engine.RAY, workers=2)
    assert sorted(a.analysed) == sorted(b.analysed)
    assert a.failed == b.failed
    ra, rb = read_records(local), read_records(remote)
    assert len(ra) == 5
    assert json.dumps(ra, sort_keys=True) == json.dumps(rb, sort_keys=True)
    ta = pl.read_parquet(local / "fleet.parquet")
    tb = pl.read_parquet(remote / "fleet.parquet")
    assert ta.height > 0
    assert ta.equals(tb)
    assert (local / "fleet.json").read_text() == (remote / "fleet.json").read_text()
