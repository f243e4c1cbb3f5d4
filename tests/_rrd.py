"""Reading a saved Rerun recording (``.rrd``) back in tests (``rr.chunk.RrdReader``)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np


def rr() -> ModuleType:
    import rerun

    return rerun


class Rrd:
    """Rows of each entity of a saved recording: timelines as int64 ns, components as lists."""

    def __init__(self, path: Path) -> None:
        import pyarrow as pa

        reader = rr().chunk.RrdReader(path)
        self.blueprints = reader.blueprints()
        self.static: dict[str, dict[str, Any]] = defaultdict(dict)
        rows: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for chunk in reader.stream():
            batch = chunk.to_record_batch()
            names = [n for n in batch.schema.names if n != "rerun.controls.RowId"]
            if chunk.is_static:
                for name in names:
                    self.static[chunk.entity_path][name] = batch.column(name).to_pylist()[-1]
                continue
            cols: dict[str, list[Any]] = {}
            for name in names:
                col = batch.column(name)
                if name in chunk.timeline_names:
                    cols[name] = col.cast(pa.int64()).to_pylist()
                else:
                    cols[name] = col.to_pylist()
            for i in range(batch.num_rows):
                rows[chunk.entity_path].append({k: v[i] for k, v in cols.items()})
        self.rows = dict(rows)

    def entity(self, path: str, timeline: str = "demo_time") -> list[dict[str, Any]]:
        """Rows of an entity sorted by a timeline (log_time ignored)."""
        return sorted(self.rows[path], key=lambda r: r[timeline])

    def column(self, path: str, component: str, timeline: str = "demo_time") -> list[Any]:
        return [r[component] for r in self.entity(path, timeline) if r.get(component) is not None]

    def one(self, path: str, component: str, timeline: str = "demo_time") -> list[Any]:
        """The single instance of a component in each row."""
        return [v[0] for v in self.column(path, component, timeline)]

    def times(self, path: str, timeline: str = "demo_time") -> np.ndarray:
        return np.array([r[timeline] for r in self.entity(path, timeline)], dtype=np.int64)


def row_times(path: Path, entity: str) -> np.ndarray:
    """When each row of ``entity`` was logged: the time part of its row id (a TUID, whose first
    8 bytes are big-endian nanoseconds since the epoch)."""
    out = []
    for chunk in rr().chunk.RrdReader(path).stream():
        if chunk.entity_path == entity and not chunk.is_static:
            ids = chunk.to_record_batch().column("rerun.controls.RowId").to_pylist()
            out += [int.from_bytes(i[:8], "big") for i in ids]
    return np.array(out, dtype=np.int64)
