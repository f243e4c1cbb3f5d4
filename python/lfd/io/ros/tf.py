"""The tf tree of a bag: every transform of its tf topics, composed into chains at any times
(translation linear, rotation slerp)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import RecordingFormatError, UsageError
from .mapping import _frame


def _stamp(header: Any, log_ns: int, time: str) -> int:
    if time == "receive":
        return log_ns
    s = header.stamp
    ns = int(s.sec) * 1_000_000_000 + int(s.nanosec)
    return ns if ns > 0 else log_ns


def _matrix(p: Any, q: Any) -> np.ndarray:
    """A 4x4 transform of a translation and an (x, y, z, w) quaternion."""
    from scipy.spatial.transform import Rotation

    m = np.eye(4)
    qa = np.asarray(q, dtype=np.float64)
    if np.all(np.isfinite(qa)) and np.linalg.norm(qa) > 0:
        m[:3, :3] = Rotation.from_quat(qa).as_matrix()
    m[:3, 3] = p
    return m


def _check_transform(p: np.ndarray, q: np.ndarray, where: str, child: str) -> None:
    """Refuse a tf transform that is no rigid motion: a quaternion that is zero (no rotation
    at all, not the identity: that is 0, 0, 0, 1), NaN or infinite, or such a translation."""
    if not (np.all(np.isfinite(q)) and np.linalg.norm(q) > 1e-9):
        raise RecordingFormatError(
            f"{where}: the transform to frame {child!r} has rotation quaternion "
            f"{', '.join(f'{v:g}' for v in q)} (x, y, z, w), which is not a rotation"
        )
    if not np.all(np.isfinite(p)):
        raise RecordingFormatError(
            f"{where}: the transform to frame {child!r} has translation "
            f"{', '.join(f'{v:g}' for v in p)}, which is not finite"
        )


class _TfTree:
    """Every transform of the tf topics; ``ref_T(frame, times)`` composes a chain at times."""

    def __init__(self) -> None:
        self.parent: dict[str, str] = {}
        self.samples: dict[str, list[tuple[int, np.ndarray, np.ndarray]]] = {}
        self.static: set[str] = set()

    def add(self, parent: str, child: str, t: int, p: np.ndarray, q: np.ndarray, static: bool):  # type: ignore[no-untyped-def]
        parent, child = _frame(parent), _frame(child)
        self.parent[child] = parent
        self.samples.setdefault(child, []).append((t, p, q))
        if static:
            self.static.add(child)

    @property
    def frames(self) -> list[str]:
        return sorted(set(self.parent) | set(self.parent.values()))

    def times(self, child: str) -> np.ndarray:
        """Distinct sample times of the edge into ``child``, sorted."""
        return np.unique(np.array([s[0] for s in self.samples.get(child, [])], dtype=np.int64))

    def _edge(self, child: str, times: np.ndarray) -> np.ndarray:
        """parent_T_child at ``times``, shape (n, 4, 4): interpolated (translation linear,
        rotation slerp), held constant before the first and after the last sample."""
        from scipy.spatial.transform import Rotation, Slerp

        items = sorted(self.samples[child], key=lambda s: s[0])
        t = np.array([s[0] for s in items], dtype=np.int64)
        _, first = np.unique(t, return_index=True)
        t = t[first]
        p = np.array([items[i][1] for i in first], dtype=np.float64)
        q = np.array([items[i][2] for i in first], dtype=np.float64)
        out = np.tile(np.eye(4), (len(times), 1, 1))
        if child in self.static or len(t) == 1:
            out[:] = _matrix(p[-1], q[-1])
            return out
        x = (times - t[0]) * 1e-9
        xs = (t - t[0]) * 1e-9
        for k in range(3):
            out[:, k, 3] = np.interp(x, xs, p[:, k])
        rot = Slerp(xs, Rotation.from_quat(q))(np.clip(x, xs[0], xs[-1]))
        out[:, :3, :3] = rot.as_matrix()
        return out

    def _chain(self, frame: str) -> list[str]:
        chain = [frame]
        while chain[-1] in self.parent and len(chain) <= len(self.parent):
            chain.append(self.parent[chain[-1]])
        return chain

    def _root_T(self, chain: list[str], upto: str, times: np.ndarray) -> np.ndarray:
        """upto_T_chain[0] at ``times`` (``upto`` is in ``chain``)."""
        out = np.tile(np.eye(4), (len(times), 1, 1))
        for child in chain[: chain.index(upto)]:
            out = self._edge(child, times) @ out
        return out

    def ref_T(self, ref: str, frame: str, times: np.ndarray, where: str) -> np.ndarray:
        """ref_T_frame at ``times``, shape (n, 4, 4)."""
        if frame == ref:
            return np.tile(np.eye(4), (len(times), 1, 1))
        a, b = self._chain(frame), self._chain(ref)
        common = next((f for f in a if f in b), None)
        if common is None:
            raise UsageError(
                f"{where}: no tf path from frame {frame!r} to the reference frame {ref!r}; "
                f"tf frames in the bag: {', '.join(self.frames) or 'none'}"
            )
        anc_T_frame = self._root_T(a, common, times)
        anc_T_ref = self._root_T(b, common, times)
        return np.linalg.inv(anc_T_ref) @ anc_T_frame
