"""Two-hand tasks for one arm, made from a shipped one-hand recording: the recorded hand as the
right one, and a left hand that rests away from the objects (its lane one ``move``) or whose
lane does a known part of the task (labels only: a handover, a hold); saved with lfd.save."""

from __future__ import annotations

import dataclasses

import numpy as np
from lfd import Demonstration, Handover, SkillLabel

SEC = 1_000_000_000


def resting_left(demo: Demonstration, offset: tuple[float, float, float] = (0.0, 0.6, 0.0)):
    """``demo``'s hand as the right hand and a left hand held still ``offset`` metres from the
    right hand's first pose (away from every object), with the same samples and confidence."""
    kp = np.broadcast_to(demo.hand.keypoints[:1] + np.asarray(offset), demo.hand.keypoints.shape)
    return dataclasses.replace(demo.hand, side="left", keypoints=kp.copy())


def idle_left(demo: Demonstration) -> Demonstration:
    """``demo`` with a resting left hand whose ground-truth lane is one ``move``: the right
    hand does all of the task."""
    labels = [dataclasses.replace(lab, hand="right") for lab in demo.labels]
    labels.append(SkillLabel("move", demo.start_ns, demo.end_ns, None, hand="left"))
    labels.sort(key=lambda lab: (lab.start_ns, lab.end_ns))  # as lfd.save writes them
    return dataclasses.replace(demo, other_hand=resting_left(demo), labels=labels, live_segments=[])


def handover_labels(t0: int) -> tuple[list[SkillLabel], list[Handover]]:
    """A handover of box_2 from the right hand to the left at 3.0-3.4 s, then the left hand
    places it; meanwhile nothing else (times from ``t0``)."""
    s = lambda x: t0 + round(x * SEC)  # noqa: E731
    right = [
        ("pick_up", 0.0, 1.6, "box_2"),
        ("move_with", 1.6, 3.0, "box_2"),
        ("place", 3.0, 3.4, "box_2"),
        ("move", 3.4, 14.7, None),
    ]
    left = [
        ("move", 0.0, 2.0, "box_2"),
        ("pick_up", 2.0, 3.0, "box_2"),
        ("move_with", 3.0, 4.0, "box_2"),
        ("place", 4.0, 5.0, "box_2"),
        ("move", 5.0, 14.7, None),
    ]
    labels = [SkillLabel(k, s(a), s(b), o, hand="right") for k, a, b, o in right]
    labels += [SkillLabel(k, s(a), s(b), o, hand="left") for k, a, b, o in left]
    labels.sort(key=lambda lab: (lab.start_ns, lab.end_ns))
    return labels, [Handover(s(3.0), s(3.4), "right", "left", "box_2")]


def hold_labels(t0: int) -> list[SkillLabel]:
    """The right hand holds box_2 still (``move_with`` 1.6-10 s) while the left hand picks up
    box_3 and stacks it on box_2 (the stack ends at 9.0 s)."""
    s = lambda x: t0 + round(x * SEC)  # noqa: E731
    right = [
        ("pick_up", 0.0, 1.6, "box_2"),
        ("move_with", 1.6, 10.0, "box_2"),
        ("place", 10.0, 11.0, "box_2"),
        ("move", 11.0, 14.7, None),
    ]
    left = [
        ("move", 0.0, 2.0, "box_3"),
        ("pick_up", 2.0, 4.0, "box_3"),
        ("move_with", 4.0, 7.0, "box_3"),
        ("stack", 7.0, 9.0, "box_3"),
        ("move", 9.0, 14.7, None),
    ]
    return [SkillLabel(k, s(a), s(b), o, hand="right") for k, a, b, o in right] + [
        SkillLabel(k, s(a), s(b), o, hand="left") for k, a, b, o in left
    ]


def busy_left(demo: Demonstration, labels: list[SkillLabel], handovers=()) -> Demonstration:
    """``demo`` with a resting left hand and the two-hand ``labels`` (and handovers)."""
    return dataclasses.replace(
        demo,
        other_hand=resting_left(demo),
        labels=labels,
        handovers=list(handovers),
        live_segments=[],
    )
