"""The simulated demonstrator: a capsule human hand performing the seven skills in MuJoCo.

It is the test bed for segmentation, reproduction and perception: :func:`simulate` runs a task
(``exp1`` ... ``exp6``, a single-skill template task, or a two-hand task: ``handover``,
``carry``, ``hold_stack``, ``hold_push``, :mod:`lfd.sim.bimanual`) like a person would — imprecisely, at
varying speed, with detours and pauses — and records it like a real demonstration (hand
keypoints at ~5 Hz, object tag poses at 30 Hz, optional RGB-D frames), with ground-truth skill
labels. ``Variability(style="natural")`` selects a faster demonstrator recorded like motion
capture (see :mod:`lfd.sim.natural`). MuJoCo and OpenCV (the ``sim`` extra) are needed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .. import _gl  # noqa: F401  (selects the headless GL backend before mujoco loads)

if TYPE_CHECKING:
    from .demonstrator import SIM_VERSION, SimResult, Truth, simulate, truth_demonstration
    from .scene import DEFAULT_OBJECTS, CameraSpec, ObjectSpec, Scene, build_scene
    from .tasks import (
        BIMANUAL_TASKS,
        EXPERIMENTS,
        NATURAL_EXPERIMENTS,
        REPEAT_EXPERIMENTS,
        TASK_GENERATORS,
        TASK_NAMES,
        TASKS,
        TEMPLATE_TASKS,
        TRANSITIONS,
        TWO_HAND_EXPERIMENTS,
        check_grammar,
    )
    from .variability import STYLES, Variability

_HOME = {
    **dict.fromkeys(
        ("SIM_VERSION", "SimResult", "Truth", "simulate", "truth_demonstration"), "demonstrator"
    ),
    **dict.fromkeys(
        ("DEFAULT_OBJECTS", "CameraSpec", "ObjectSpec", "Scene", "build_scene"), "scene"
    ),
    **dict.fromkeys(
        (
            "BIMANUAL_TASKS",
            "EXPERIMENTS",
            "NATURAL_EXPERIMENTS",
            "REPEAT_EXPERIMENTS",
            "TASK_GENERATORS",
            "TASK_NAMES",
            "TASKS",
            "TEMPLATE_TASKS",
            "TRANSITIONS",
            "TWO_HAND_EXPERIMENTS",
            "check_grammar",
        ),
        "tasks",
    ),
    **dict.fromkeys(("STYLES", "Variability"), "variability"),
}
"""The module of each name this package exports: imported when the name is first used, so
``lfd simulate --help`` (the task names) does not load the simulator."""


def __getattr__(name: str) -> Any:
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    module = importlib.import_module(f".{home}", __name__)
    return getattr(module, name)


__all__ = [
    "BIMANUAL_TASKS",
    "DEFAULT_OBJECTS",
    "EXPERIMENTS",
    "NATURAL_EXPERIMENTS",
    "REPEAT_EXPERIMENTS",
    "SIM_VERSION",
    "STYLES",
    "TASKS",
    "TASK_GENERATORS",
    "TASK_NAMES",
    "TEMPLATE_TASKS",
    "TRANSITIONS",
    "TWO_HAND_EXPERIMENTS",
    "CameraSpec",
    "ObjectSpec",
    "Scene",
    "SimResult",
    "Truth",
    "Variability",
    "build_scene",
    "check_grammar",
    "simulate",
    "truth_demonstration",
]
