"""Entity paths shared by the offline views and the live logger (:mod:`lfd.viz.live`): one
definition, so a live session looks like the offline one (layout: :mod:`lfd.viz.blueprint`)."""

from __future__ import annotations

HAND_KEYPOINTS = "/world/hand/keypoints"
"""The 21 hand keypoints per sample (skeleton from the ``/world/hand`` annotation context)."""
HAND = "/world/hand"
"""The hand; of two hands, each below it by side: ``/world/hand/<side>/keypoints``, ``/path``,
``/gripper``, ``/tcp_path``, ``/gripper_trail`` (:func:`hand_path`)."""
CAMERA_COLOR = "/camera/color"
OBJECTS = "/world/objects"
"""Object frames: ``/world/objects/<name>``, the box below it (``/box``)."""
FEATURES = "/features"
"""Feature series: ``/features/<name>/value``, ``/threshold`` (and ``/threshold_neg``)."""
FEATURE_TARGET = "/features/target"
"""The target object per sample (a state lane)."""
SECTIONS = "/segmentation/sections"
"""Stage-1 data sections (a state lane)."""
SKILLS = "/segmentation/skills"
"""Skill lanes: ``/segmentation/skills/<source>`` (``result``, ``ground_truth``, ...)."""
PROVISIONAL = "provisional"
"""Lane (under :data:`SKILLS`) of the live segmenter's open span, before it settles."""
HANDOVERS = "/segmentation/handovers"
"""Handover lanes: ``/segmentation/handovers/<source>`` (``result``, ``ground_truth``)."""
WORLD_HANDOVERS = "/world/handovers"
"""Handovers in 3-D: ``/world/handovers/<source>``, a labelled point where each took place."""
GREEDY = "/segmentation/greedy"
"""Stage-2 HMM scores."""
WARNINGS = "/segmentation/warnings"
LOG = "/segmentation/log"


def _part(name: str) -> str:
    from .recording import import_rerun

    return str(import_rerun().escape_entity_path_part(name))


def object_path(name: str) -> str:
    """``/world/objects/<name>`` (the name escaped)."""
    return f"{OBJECTS}/{_part(name)}"


def feature_path(name: str) -> str:
    """``/features/<name>``."""
    return f"{FEATURES}/{name}"


def skill_lane(source: str) -> str:
    """``/segmentation/skills/<source>`` (the source escaped)."""
    return f"{SKILLS}/{_part(source)}"


def hand_path(side: str | None, part: str) -> str:
    """Where ``part`` (``keypoints``, ``path``, ``gripper``, ``tcp_path``, ``gripper_trail``)
    of a hand is: of the only hand (``side`` None) where a one-hand view has it
    (``/world/hand/keypoints``, ``/world/hand/path``, ``/world/gripper``, ...), of one of two
    hands ``/world/hand/<side>/<part>``."""
    if side is None:
        return f"{HAND}/{part}" if part in ("keypoints", "path") else f"/world/{part}"
    return f"{HAND}/{_part(side)}/{part}"


def hand_lane(side: str | None, source: str) -> str:
    """The skill lane of ``source``: ``/segmentation/skills/<source>`` of the only hand
    (``side`` None), ``/segmentation/skills/<side>/<source>`` of one of two."""
    if side is None:
        return skill_lane(source)
    return f"{SKILLS}/{_part(side)}/{_part(source)}"
