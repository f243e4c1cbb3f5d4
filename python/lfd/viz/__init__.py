"""Rerun views of every lfd stage: live while it runs, saved to ``.rrd``, served to a browser.

Notebook use::

    import lfd, lfd.viz
    session = lfd.viz.init("lfd", spawn=True)          # or save="demo.rrd", serve=True
    lfd.viz.log_demonstration(demo, trajectory=traj)
    lfd.viz.log_features(features)
    lfd.viz.log_segmentation(result.segments, ground_truth=demo.labels)

Every function takes ``recording=`` (a ``rerun.RecordingStream``), default the current one.
``rerun`` itself is imported on first use (with ``RERUN_TELEMETRY=0`` unless set), so importing
this package is cheap. Entity paths and the layout: :mod:`lfd.viz.blueprint`; timelines:
:mod:`lfd.viz.timeline`.
"""

from __future__ import annotations

from .blueprint import FEATURE_NAMES, default_blueprint
from .demo import log_demonstration
from .features import log_feature_arrays, log_features
from .recording import import_rerun
from .robot import log_reproduction, log_robot_paths
from .segmentation import (
    log_greedy_scores,
    log_sections,
    log_segmentation,
    log_skill_spans,
    log_text,
)
from .session import Session, init, open_session
from .timeline import DEMO_TIME, FRAME, ROBOT_TIME, set_time_origin

__all__ = [
    "DEMO_TIME",
    "FEATURE_NAMES",
    "FRAME",
    "ROBOT_TIME",
    "Session",
    "default_blueprint",
    "import_rerun",
    "init",
    "log_demonstration",
    "log_feature_arrays",
    "log_features",
    "log_greedy_scores",
    "log_reproduction",
    "log_robot_paths",
    "log_sections",
    "log_segmentation",
    "log_skill_spans",
    "log_text",
    "open_session",
    "set_time_origin",
]
