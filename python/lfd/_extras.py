"""The optional extras (``pyproject.toml``'s optional dependencies) and the one line that says
which one to install when a module of it is missing.

Every command needing an extra says so in one line, ``lfd <command>: error: <message>`` with
exit status 2, however the module goes missing: :func:`require` checks before any work (for
modules found missing only late, like the QP solver ``daqp`` that mink looks up at the first IK
step, or ``movement_primitives`` at the first DMP), and :func:`lfd.cli.main` turns a
``ModuleNotFoundError`` of any module listed here into the same line (:func:`message_for`).
Library functions raise :class:`~lfd.errors.MissingExtraError` (an :class:`~lfd.errors.LfdError`)
with the same text.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass

from .errors import MissingExtraError

__all__ = ["EXTRAS", "Extra", "extra_of", "install_hint", "message_for", "missing", "require"]


@dataclass(frozen=True)
class Extra:
    """An extra: what it provides (for the message) and the top-level modules it installs."""

    name: str
    needs: str
    """What is missing, as the message says it: ``this command needs <needs>: pip install ...``."""
    modules: tuple[str, ...]
    install: str


LEROBOT_MODULES = ("lerobot", "datasets", "huggingface_hub", "av", "torch", "torchvision")
"""What ``lerobot``'s dataset code imports (the extra itself installs lerobot's dependencies;
lerobot goes in with ``--no-deps``: its pins conflict with the viz and perception extras)."""
LEROBOT_INSTALL = "pip install 'lfd[lerobot]' && pip install --no-deps lerobot==0.4.4"
ROBOTS_INSTALL = "pip install --no-deps robosuite==1.5.2"
"""The robot models of ``lfd reproduce --robot panda``: robosuite's MJCF and meshes, read by path
and never imported (its pins, mink==0.0.5 and opencv-python, clash with ours)."""

ALOHA_INSTALL = "pip install --no-deps gym-aloha==0.1.5"

EXTRAS: dict[str, Extra] = {
    e.name: e
    for e in (
        Extra(
            "sim",
            "the simulator",
            ("mujoco", "cv2", "mink", "daqp", "movement_primitives", "pytransform3d"),
            "pip install 'lfd[sim]'",
        ),
        Extra(
            # the perception commands read images with OpenCV, which the sim extra installs
            "perception",
            "the hand models and OpenCV",
            ("torch", "ai_edge_litert", "cv2"),
            "pip install 'lfd[sim,perception]'",
        ),
        Extra("viz", "Rerun (rerun-sdk)", ("rerun",), "pip install 'lfd[viz]'"),
        Extra("ros", "the rosbags package", ("rosbags",), "pip install 'lfd[ros]'"),
        Extra("lerobot", "lerobot", LEROBOT_MODULES, LEROBOT_INSTALL),
        Extra("robots", "robosuite's robot models", ("robosuite",), ROBOTS_INSTALL),
        Extra("ray", "Ray", ("ray",), "pip install 'lfd[ray]'"),
        # the two-arm ALOHA's MJCF and meshes (lfd.reproduce.aloha; gym-aloha's pins clash)
        Extra("aloha", "gym-aloha's robot models", ("gym_aloha",), ALOHA_INSTALL),
    )
}


def install_hint(extra: str) -> str:
    """The command that installs ``extra``, e.g. ``pip install 'lfd[sim]'``."""
    return EXTRAS[extra].install


def missing(extra: str, modules: tuple[str, ...] | None = None) -> str | None:
    """The first of ``modules`` (default: all of the extra's) that is not installed, or None.

    Looks the modules up without importing them (a module blocked by ``sys.modules[name] =
    None`` counts as missing)."""
    for name in EXTRAS[extra].modules if modules is None else modules:
        try:
            if importlib.util.find_spec(name) is None:
                return name
        except (ImportError, ValueError):
            return name
    return None


def message(extra: str, module: str | None = None, *, who: str = "this command") -> str:
    """``<who> needs <what> (<module> is missing): <install>``, one line."""
    e = EXTRAS[extra]
    # lerobot's extra has many modules: name the one missing (the others' lines are fixed)
    why = f" ({module} is missing)" if module and extra == "lerobot" else ""
    return f"{who} needs {e.needs}{why}: {e.install}"


def require(
    extra: str, modules: tuple[str, ...] | None = None, *, who: str = "this command"
) -> None:
    """Raise :class:`MissingExtraError` naming ``extra`` when one of ``modules`` (default: all
    of the extra's) is not installed."""
    name = missing(extra, modules)
    if name is not None:
        raise MissingExtraError(message(extra, name, who=who), extra=extra, module=name)


def extra_of(module: str, prefer: tuple[str, ...] = ()) -> str | None:
    """The extra that installs the top-level module of ``module`` (dotted names allowed), or
    None; ``prefer`` lists extras to try first (a module in several, like torch)."""
    top = module.split(".")[0]
    for name in (*prefer, *EXTRAS):
        if name in EXTRAS and top in EXTRAS[name].modules:
            return name
    return None


def message_for(module: str, prefer: tuple[str, ...] = ()) -> str | None:
    """The one-line message for a missing ``module`` of an extra, or None if no extra has it."""
    extra = extra_of(module, prefer)
    return None if extra is None else message(extra, module.split(".")[0])
