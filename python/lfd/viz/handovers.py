"""Log handovers (an object passed from one hand to the other, :class:`lfd.Handover`): a state
lane on the timeline, ``/segmentation/handovers/<source>``, one span per handover from the
taker's grasp to the giver's release; and in 3-D, ``/world/handovers/<source>``, a labelled
point where each took place (the object's position at the release, else midway between the
hands)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .paths import HANDOVERS, WORLD_HANDOVERS
from .recording import get_recording, import_rerun
from .timeline import time_columns, time_origin

if TYPE_CHECKING:
    from ..demo import Demonstration, Handover

HANDOVER_COLOR = (255, 64, 160)
"""The colour of a handover, on the timeline and in 3-D."""
GROUND_TRUTH_COLOR = (255, 170, 210)


def handover_state(h: Handover) -> str:
    """The state (and label) of a handover: ``box_1 right→left``."""
    return f"{h.object or 'object'} {h.giver}→{h.taker}"


def handover_position(demo: Demonstration, h: Handover) -> np.ndarray | None:
    """Where a handover took place: the object's position nearest its end (the giver's
    release), else midway between the hands' TCPs ``(I + T) / 2`` then; None if unknown."""
    t = int(h.end_ns)
    obj = demo.objects.get(h.object) if h.object is not None else None
    if obj is not None and len(obj):
        ok = obj.visible & np.all(np.isfinite(obj.position), axis=1)
        if ok.any():
            idx = np.flatnonzero(ok)
            return np.asarray(obj.position[idx[np.argmin(np.abs(obj.t_ns[idx] - t))]], float)
    points = []
    for side in (h.giver, h.taker):
        hand = demo.hands.get(side)
        if hand is None or not len(hand):
            continue
        tcp = 0.5 * (hand.keypoints[:, 4] + hand.keypoints[:, 8])
        ok = np.flatnonzero(np.all(np.isfinite(tcp), axis=1))
        if ok.size:
            points.append(tcp[ok[np.argmin(np.abs(hand.t_ns[ok] - t))]])
    return np.mean(points, axis=0) if points else None


def log_handovers(
    handovers: Sequence[Handover],
    *,
    source: str = "result",
    demo: Demonstration | None = None,
    positions: Sequence[np.ndarray | None] | None = None,
    recording: Any = None,
    origin_ns: int | None = None,
) -> None:
    """Log handovers as spans in the lane ``/segmentation/handovers/<source>`` and as labelled
    points in ``/world/handovers/<source>`` (where: ``positions``, one per handover, or found
    in ``demo`` by :func:`handover_position`; a handover without one gets no point).

    Logging again replaces the 3-D points (a live view logs all handovers so far each time)."""
    rr = import_rerun()
    rec = get_recording(recording)
    hs = sorted(handovers, key=lambda h: int(h.start_ns))
    if not hs:
        return
    origin = time_origin(rec, first_ns=int(hs[0].start_ns), origin_ns=origin_ns)
    color = HANDOVER_COLOR if source != "ground_truth" else GROUND_TRUTH_COLOR
    lane = f"{HANDOVERS}/{source}"
    states = list(dict.fromkeys(handover_state(h) for h in hs))
    rgba = (color[0] << 24) | (color[1] << 16) | (color[2] << 8) | 0xFF
    rec.log(
        lane,
        rr.StateConfiguration(values=states, colors=np.full(len(states), rgba, dtype=np.uint32)),
        static=True,
    )
    times: list[int] = []
    values: list[str] = []
    for i, h in enumerate(hs):
        times.append(int(h.start_ns))
        values.append(handover_state(h))
        nxt = hs[i + 1] if i + 1 < len(hs) else None
        if nxt is None or int(nxt.start_ns) > int(h.end_ns):
            times.append(int(h.end_ns))
            values.append("")
    rec.send_columns(
        lane,
        indexes=time_columns(np.asarray(times, dtype=np.int64), origin),
        columns=rr.StateChange.columns(state=values),
    )
    if positions is None:
        positions = [handover_position(demo, h) if demo is not None else None for h in hs]
    else:
        order = sorted(range(len(handovers)), key=lambda i: int(handovers[i].start_ns))
        positions = [positions[i] for i in order]
    where = [(p, h) for p, h in zip(positions, hs, strict=True) if p is not None]
    if where:
        rec.log(
            f"{WORLD_HANDOVERS}/{source}",
            rr.Points3D(
                [p for p, _ in where],
                labels=[
                    f"handover {handover_state(h)} at {(int(h.start_ns) - origin) * 1e-9:.1f} s"
                    for _, h in where
                ],
                colors=[color],
                radii=0.015,
            ),
            static=True,
        )
