"""A robot is a value: one :class:`Robot` describes an arm with its gripper (MJCF, joints and
limits, home pose, TCP, gripper geometry, reach, TCP speed limits), and the reproduction reads it
(:mod:`.scene`, :mod:`.ik`, :mod:`.controller`, :mod:`.goals`, :mod:`.modes`, :mod:`.motion`,
:mod:`.displacement`, :mod:`.timescale`). :data:`ROBOTS` names every robot; :func:`robot` builds
one (``lfd reproduce --robot NAME``).

A new robot is one module that builds a :class:`Robot` and one entry of :data:`ROBOTS`:

* ``kuka_lwr4`` (the default): the hand-written KUKA LWR 4+ with a parallel-jaw gripper
  (:mod:`.robot`);
* ``panda``: the Franka Emika Panda with its hand, from the MJCF and meshes of the
  ``robosuite`` wheel (:mod:`.panda`; the ``robots`` extra).

Conventions every robot follows (the reproduction relies on them): the arm's MJCF body tree is
placed inside ``<body name="robot_base">`` at the base position (z = 0 is the table top), the
arm joints come first in ``qpos`` and ``ctrl`` (position servos), then the two finger joints
(position servos, each opening by half the commanded opening, 0 = closed); the site ``tcp`` is
the centre between the finger pads, its z axis the approach direction and its y axis the
closing direction; the body ``gripper`` holds the palm (contacts between it and the fingers are
excluded).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache

from .aloha import TwoArmRobot, aloha
from .arm import Limits, Robot
from .panda import panda, two_pandas
from .robot import KUKA_LWR4

__all__ = [
    "DEFAULT_ROBOT",
    "ROBOTS",
    "TWO_ARM_ROBOTS",
    "Limits",
    "Robot",
    "any_robot",
    "robot",
    "robot_names",
]


def _kuka() -> Robot:
    return KUKA_LWR4


ROBOTS: dict[str, Callable[[], Robot]] = {"kuka_lwr4": _kuka, "panda": panda}
"""Every robot by name: a function that builds it (a robot from an optional package is built
when asked for, and says in one line how to install it when the package is missing)."""
DEFAULT_ROBOT = "kuka_lwr4"
TWO_ARM_ROBOTS: dict[str, Callable[[], TwoArmRobot]] = {"aloha": aloha, "two_pandas": two_pandas}
"""Every two-arm robot by name (``lfd reproduce --robot NAME``): a function that builds it."""


def robot_names() -> tuple[str, ...]:
    """The registry's names, the default first."""
    return (DEFAULT_ROBOT, *sorted(n for n in ROBOTS if n != DEFAULT_ROBOT))


@cache
def robot(name: str = DEFAULT_ROBOT) -> Robot:
    """The robot called ``name`` (:data:`ROBOTS`).

    Raises
    ------
    UsageError
        An unknown name (the message lists the known robots).
    MissingExtraError
        The robot's model comes from a package that is not installed.
    """
    from ..errors import UsageError

    if name in TWO_ARM_ROBOTS:
        raise UsageError(f"{name} has two arms; one arm is one of: {', '.join(robot_names())}")
    if name not in ROBOTS:
        raise UsageError(f"unknown robot {name!r}; known robots: {_known()}")
    return ROBOTS[name]()


def _known() -> str:
    return f"{', '.join(robot_names())} (one arm), {', '.join(sorted(TWO_ARM_ROBOTS))} (two arms)"


def any_robot(name: str = DEFAULT_ROBOT) -> Robot | TwoArmRobot:
    """The robot called ``name``: one arm (:data:`ROBOTS`) or two (:data:`TWO_ARM_ROBOTS`,
    :mod:`.aloha`); what ``lfd reproduce --robot NAME`` checks before any work.

    Raises
    ------
    UsageError
        An unknown name (the message lists the known robots).
    MissingExtraError
        The robot's model comes from a package that is not installed.
    """
    return TWO_ARM_ROBOTS[name]() if name in TWO_ARM_ROBOTS else robot(name)
