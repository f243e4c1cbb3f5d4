"""Two-hand recordings made with lfd's own writer for the tests: a shipped recording given a
second hand (its own hand mirrored and shifted, on the same clock), labels in both lanes and a
handover."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import lfd
import numpy as np
from _paths import EXP1
from lfd.demo import Demonstration, Handover, HandTrack


def left_of(hand: HandTrack, shift_ns: int = 7_000_000, dx: float = 0.3) -> HandTrack:
    """A left hand beside ``hand``: its keypoints moved ``dx`` m along x, its times ``shift_ns``
    later (a second camera's stamps on the same clock)."""
    return HandTrack(
        t_ns=hand.t_ns + shift_ns,
        keypoints=hand.keypoints + np.array([dx, 0.0, 0.0]),
        confidence=hand.confidence * 0.9,
        side="left",
        visible=hand.visible,
    )


def two_hand_demo(src: Path = EXP1) -> Demonstration:
    """``src`` with a left hand: the right lane keeps the labels, the left lane takes the
    first two, and one handover (right to left) of the first label's object."""
    demo = lfd.load(src, images=False)
    right = [dataclasses.replace(lab, hand="right") for lab in demo.labels]
    left = [dataclasses.replace(lab, hand="left") for lab in demo.labels[:2]]
    given = demo.labels[1]
    return dataclasses.replace(
        demo,
        other_hand=left_of(demo.hand),
        labels=sorted(right + left, key=lambda lab: (lab.start_ns, lab.end_ns)),
        handovers=[Handover(given.start_ns, given.end_ns, "right", "left", given.object)],
        metadata={k: v for k, v in demo.metadata.items() if k != "load_report"},
    )


def save_two_hands(path: Path, src: Path = EXP1) -> Demonstration:
    """Write :func:`two_hand_demo` to ``path`` with :func:`lfd.save`; return what was saved."""
    demo = two_hand_demo(src)
    lfd.save(demo, path)
    return demo
