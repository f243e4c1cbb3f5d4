"""Entity paths shared by the offline views and the live logger (:mod:`lfd.viz.live`): one
definition, so a live session looks like the offline one (layout: :mod:`lfd.viz.blueprint`)."""

from __future__ import annotations

HAND_KEYPOINTS = "/world/hand/keypoints"
CAMERA_COLOR = "/camera/color"
"""The 21 hand keypoints per sample (skeleton from the ``/world/hand`` annotation context)."""
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
