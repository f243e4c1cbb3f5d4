"""Simulated two-hand demonstrations as the two-arm robots take them (tests/unit/reproduce:
the ALOHA and the two Pandas)."""

from __future__ import annotations


def program(task: str, seed: int, style: str = "careful"):  # type: ignore[no-untyped-def]
    """Each hand's preprocessed trajectory and the two-hand program of the simulated ``task``
    (``seed``, a ``careful`` or ``natural`` demonstrator)."""
    from lfd.preprocessing import preprocess
    from lfd.reproduce import PREPROCESSING, from_hand_labels
    from lfd.sim import Variability, simulate

    demo = simulate(task, seed=seed, variability=Variability(style=style)).demo
    hands = from_hand_labels(
        demo.labels, demo.start_ns, sides=demo.sides, handovers=demo.handovers, objects=demo.objects
    )
    return {s: preprocess(demo.one_hand(s), **PREPROCESSING) for s in demo.sides}, hands
