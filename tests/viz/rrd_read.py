"""Read a .rrd back with ``rerun.chunk.RrdReader`` into plain numpy, per entity and component."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from rerun.chunk import RrdReader

from viz.style import TIMELINE


@dataclass
class Entity:
    """Temporal rows (time in ns, and per component one python value per row) and statics."""

    times_ns: list[int] = field(default_factory=list)
    temporal: dict[str, list] = field(default_factory=lambda: defaultdict(list))
    static: dict[str, object] = field(default_factory=dict)

    def rows(self, component: str) -> tuple[np.ndarray, list]:
        """(times_ns sorted, values in the same order) of ``component`` ("Points2D:positions")."""
        t = np.asarray(self.times_ns, dtype=np.int64)
        order = np.argsort(t, kind="stable")
        vals = self.temporal[component]
        return t[order], [vals[i] for i in order]


def read_rrd(path: str | Path) -> tuple[dict[str, Entity], int]:
    """Entities of the first recording and the number of blueprint stores in ``path``."""
    reader = RrdReader(path)
    out: dict[str, Entity] = defaultdict(Entity)
    for chunk in reader.stream().to_chunks():
        rb = chunk.to_record_batch()
        ent = out[chunk.entity_path]
        comps = [n for n in rb.schema.names if ":" in n]
        if chunk.is_static:
            for c in comps:
                ent.static[c] = rb.column(c).to_pylist()[-1]
            continue
        ts = rb.column(TIMELINE).cast("int64").to_pylist()
        start = len(ent.times_ns)
        ent.times_ns.extend(ts)
        for c in comps:
            col = ent.temporal[c]
            col.extend([None] * (start - len(col)))
            col.extend(rb.column(c).to_pylist())
    return dict(out), len(reader.blueprints())
