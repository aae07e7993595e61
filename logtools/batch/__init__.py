"""Batch analysis of a log archive (``logcal batch``, ``logcal serve``): every log analysed in
parallel and resumably, fleet results in one Parquet table, pooled estimates and drift per
robot, and an HTML report. See docs/batch.md.

Modules: :mod:`~logtools.batch.files` (regular files only), :mod:`~logtools.batch.settings`
(``logcal.toml``, keys from the robot plugins' options), :mod:`~logtools.batch.archive`
(walk over the registered log formats, content hash), :mod:`~logtools.batch.worker` (one
log), :mod:`~logtools.batch.engines` (process pool, Ray), :mod:`~logtools.batch.runner`
(resume, atomic writes),
:mod:`~logtools.batch.table` (fleet table; its statistics, the pooled estimates and the
drift, are :mod:`calib.pooling.meta`'s and :mod:`calib.pooling.drift`'s),
:mod:`~logtools.batch.fleet`, :mod:`~logtools.batch.plots`, :mod:`~logtools.batch.report_html`,
:mod:`~logtools.batch.serve`.

Nothing heavy is imported here: worker processes import only what they use.
"""

from __future__ import annotations

__all__: list[str] = []
