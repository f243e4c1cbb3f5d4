"""A two-hand scene made with lfd's data model (not a test module): a handover of a box from
the right hand to the left, with its labels by docs/skills.md "Two hands"."""

from __future__ import annotations

from functools import cache

import numpy as np
from _synthetic import HAND_TEMPLATE, T0
from lfd.demo import Demonstration, Handover, HandTrack, ObjectTrack, SkillLabel

RATE = 30.0
TCP_IN_TEMPLATE = 0.5 * (HAND_TEMPLATE[4] + HAND_TEMPLATE[8])


def _path(t: np.ndarray, keys: list[tuple[float, tuple[float, float, float]]]) -> np.ndarray:
    """Positions at times ``t`` through the key points (time, xyz), smoothstep between them."""
    out = np.empty((t.size, 3))
    times = [k[0] for k in keys]
    for i, ti in enumerate(t):
        j = int(np.clip(np.searchsorted(times, ti, side="right") - 1, 0, len(keys) - 2))
        (ta, a), (tb, b) = keys[j], keys[j + 1]
        u = float(np.clip((ti - ta) / (tb - ta), 0.0, 1.0))
        u = u * u * (3 - 2 * u)
        out[i] = np.asarray(a) + u * (np.asarray(b) - np.asarray(a))
    return out


def _hand(t_ns: np.ndarray, tcp: np.ndarray, side: str) -> HandTrack:
    kp = HAND_TEMPLATE[None] - TCP_IN_TEMPLATE[None, None] + tcp[:, None, :]
    return HandTrack(t_ns, kp, np.ones((len(t_ns), 21)), side=side)


@cache
def handover_demo() -> Demonstration:
    """The right hand lifts a 6 cm box and holds it up; the left takes it at 4 s; the right
    lets go at 5 s and leaves; the left sets it down at 7.5 s and leaves."""
    t = np.arange(0.0, 10.0, 1 / RATE)
    t_ns = T0 + np.round(t * 1e9).astype(np.int64)
    box = (0.0, 0.0, 0.03)
    up, there, down = (0.0, 0.0, 0.25), (0.15, 0.0, 0.25), (0.35, 0.0, 0.03)
    right = _path(
        t,
        [
            (0, (0, -0.35, 0.15)),
            (1.0, box),
            (1.4, box),
            (2.2, up),
            (3.0, there),
            (5.0, there),
            (5.2, (0.15, -0.15, 0.3)),
            (6.0, (0.15, -0.4, 0.3)),
            (10, (0.15, -0.4, 0.3)),
        ],
    )
    left = _path(t, [(0, (0.15, 0.4, 0.2)), (3.0, (0.15, 0.4, 0.2)), (4.0, there),
                     (5.2, there), (6.6, (0.35, 0.0, 0.2)), (7.5, down), (7.9, down),
                     (9.0, (0.35, 0.4, 0.2)), (10, (0.35, 0.4, 0.2))])  # fmt: skip
    obj = np.where((t < 1.4)[:, None], np.asarray(box), right)
    obj = np.where((t >= 5.0)[:, None], left, obj)
    obj = np.where((t >= 7.9)[:, None], np.asarray(down), obj)
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (t.size, 1))
    box_track = ObjectTrack("box", 1, np.full(3, 0.06), t_ns, obj, quat, np.ones(t.size, bool))

    def ns(s: float) -> int:
        return int(T0 + round(s * 1e9))

    labels = [
        SkillLabel("move", ns(0), ns(0.6), "box", hand="right"),
        SkillLabel("pick_up", ns(0.6), ns(1.4), "box", hand="right"),
        SkillLabel("move_with", ns(1.4), ns(4.0), "box", hand="right"),
        SkillLabel("place", ns(4.0), ns(5.0), "box", hand="right"),
        SkillLabel("move", ns(5.0), int(t_ns[-1]), None, hand="right"),
        SkillLabel("move", ns(0), ns(3.4), "box", hand="left"),
        SkillLabel("pick_up", ns(3.4), ns(4.0), "box", hand="left"),
        SkillLabel("move_with", ns(4.0), ns(6.9), "box", hand="left"),
        SkillLabel("place", ns(6.9), ns(8.0), "box", hand="left"),
        SkillLabel("move", ns(8.0), int(t_ns[-1]), None, hand="left"),
    ]
    return Demonstration(
        hand=_hand(t_ns, right, "right"),
        other_hand=_hand(t_ns, left, "left"),
        objects={"box": box_track},
        labels=labels,
        handovers=[Handover(ns(4.0), ns(5.0), "right", "left", "box")],
    )
