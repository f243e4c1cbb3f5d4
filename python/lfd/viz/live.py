"""Log a demonstration to Rerun as it is recorded: samples, sections and skills as they come.

:class:`LiveTimeline` is the incremental counterpart of :func:`lfd.viz.log_demonstration`,
:func:`lfd.viz.log_features` and :func:`lfd.viz.log_segmentation`: the same entity paths
(:mod:`lfd.viz.paths`), styles and ``demo_time`` origin, so with the default blueprint a live
session looks like the offline view of the finished recording, growing. Skill spans go to the
``result`` lane when they settle; the open, still changing span to the ``provisional`` lane.
Of two hands (``sides``), each hand's keypoints and lanes are its own
(``/world/hand/<side>/keypoints``, ``/segmentation/skills/<side>/result``, ...) and the settled
handovers are marked (:mod:`lfd.viz.handovers`); the feature plots and sections are one hand's
and are not drawn.

Example::

    session = lfd.viz.open_session("lfd_live", save="live.rrd")
    live = LiveTimeline(session.recording, objects=follower.objects)
    for msg in follower:
        live.log_message(msg)                    # hand keypoints, object poses, labels
    live.log_samples(t_ns, values, thresholds)   # features, any number of rows
    live.log_section(t_ns_of_a_boundary)
    live.log_skill(segment)                      # settled: skill, start_ns, end_ns, object
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import DemonstrationError
from ..features import FEATURE_NAMES
from .demo import HAND_CLASS_ID, OBJECT_PALETTE, log_static_scene
from .features import log_feature_arrays
from .handovers import log_handovers
from .paths import (
    CAMERA_COLOR,
    GREEDY,
    PROVISIONAL,
    SECTIONS,
    WARNINGS,
    hand_lane,
    hand_path,
    object_path,
)
from .recording import get_recording, import_rerun
from .segmentation import (
    SECTION_COLORS,
    SKILL_COLORS,
    UNKNOWN_COLOR,
    SegmentLike,
    _rgba,
    skill_state,
)
from .timeline import current_origin, set_time, time_columns, time_origin

__all__ = ["LiveTimeline"]


class LiveTimeline:
    """Incremental logging of one demonstration to one Rerun recording.

    Parameters
    ----------
    recording : rerun.RecordingStream, optional
        Where to log (default: the current recording).
    origin_ns : int, optional
        Absolute time of ``demo_time = 0``; default: the recording's origin, or the first
        time logged.
    objects : iterable of (name, tag_id, size), optional
        The objects (e.g. :attr:`lfd.io.Follower.objects`): their boxes are drawn from the
        start. Objects first seen later get a frame without a box.
    feature_names : sequence of str
        The feature columns of :meth:`log_samples`.
    sides : sequence of str
        The hands recorded: with two, each hand's keypoints and lanes are its own.
    """

    POSE_HISTORY = 600
    """Object poses kept per object (20 s at 30 Hz), to place a handover settled later."""

    def __init__(
        self,
        recording: Any = None,
        *,
        origin_ns: int | None = None,
        objects: Iterable[tuple[str, int, Any]] = (),
        feature_names: Sequence[str] = FEATURE_NAMES,
        object_names: Sequence[str] | None = None,
        sides: Sequence[str] = (),
    ) -> None:
        self.rr = import_rerun()
        self.rec = get_recording(recording)
        self._origin = origin_ns
        self.feature_names = list(feature_names)
        self.object_names = list(object_names) if object_names is not None else None
        self._objects: dict[str, int] = {}
        self._sections = 0
        self._lanes: dict[str, dict[str, tuple[str, int]]] = {}
        self.samples = 0
        self.two_hands = len(sides) > 1
        self._handovers: list[Any] = []
        self._handover_points: list[np.ndarray | None] = []
        self._poses: dict[str, deque[tuple[int, np.ndarray]]] = {}
        log_static_scene(self.rec, sides)
        for side in list(sides) if self.two_hands else [None]:
            self.rec.log(
                hand_path(side, "keypoints"),
                self.rr.Points3D.from_fields(show_labels=False),
                static=True,
            )
        for name, tag_id, size in objects:
            self.declare_object(name, tag_id, size)

    # --- time ----------------------------------------------------------------------------------
    def origin(self, first_ns: int) -> int:
        """The ``demo_time`` origin (fixed by the first call when not given)."""
        if self._origin is None:
            self._origin = current_origin(self.rec)
        self._origin = time_origin(self.rec, first_ns=int(first_ns), origin_ns=self._origin)
        return self._origin

    def _cols(self, t_ns: npt.ArrayLike, frame: npt.ArrayLike | None = None) -> list[Any]:
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        return time_columns(t, self.origin(int(t.min())), frame=frame)

    # --- the scene -----------------------------------------------------------------------------
    def declare_object(self, name: str, tag_id: int = -1, size: Any = None) -> None:
        """Draw an object's frame (and its box when ``size`` is known) from now on."""
        if name in self._objects:
            return
        rr = self.rr
        k = len(self._objects)
        self._objects[name] = k
        path = object_path(name)
        if size is None:
            self.rec.log(path, rr.TransformAxes3D(0.05), static=True)
            return
        s = np.asarray(size, dtype=np.float64)
        self.rec.log(path, rr.TransformAxes3D(0.5 * float(s.max()) + 0.02), static=True)
        self.rec.log(
            f"{path}/box",
            rr.Boxes3D(
                half_sizes=[s / 2],
                labels=[f"{name} (tag {tag_id})"],
                colors=[OBJECT_PALETTE[k % len(OBJECT_PALETTE)]],
                fill_mode="transparentfillmajorwireframe",
            ),
            static=True,
        )

    def _side(self, side: str | None) -> str | None:
        """The side whose paths a hand's data go to: None (the one-hand paths) unless two."""
        return side if self.two_hands else None

    def log_hand(
        self,
        t_ns: int,
        keypoints: npt.ArrayLike,
        frame: int | None = None,
        *,
        side: str | None = None,
    ) -> None:
        """One hand sample, (21, 3) metres; NaN keypoints are not drawn; of two hands, the
        ``side`` hand's."""
        rr = self.rr
        kp = np.asarray(keypoints, dtype=np.float64)
        if kp.shape != (21, 3):
            raise DemonstrationError(f"hand keypoints must have shape (21, 3), got {kp.shape}")
        ok = np.all(np.isfinite(kp), axis=1)
        ids = np.flatnonzero(ok)
        self.rec.send_columns(
            hand_path(self._side(side), "keypoints"),
            indexes=self._cols([t_ns], None if frame is None else [frame]),
            columns=rr.Points3D.columns(
                positions=kp[ok], keypoint_ids=ids, class_ids=np.full(ids.shape, HAND_CLASS_ID)
            ).partition([ids.size]),
        )

    def log_object(
        self, name: str, t_ns: int, position: npt.ArrayLike, quaternion: npt.ArrayLike
    ) -> None:
        """One object pose (position (3,) metres, quaternion (4,) x, y, z, w)."""
        self.declare_object(name)
        if self.two_hands:  # where a handover settled later took place
            poses = self._poses.setdefault(name, deque(maxlen=self.POSE_HISTORY))
            poses.append((int(t_ns), np.asarray(position, dtype=np.float64).reshape(3)))
        self.rec.send_columns(
            object_path(name),
            indexes=self._cols([t_ns]),
            columns=self.rr.Transform3D.columns(
                translation=np.asarray(position, dtype=np.float64).reshape(1, 3),
                quaternion=np.asarray(quaternion, dtype=np.float64).reshape(1, 4),
            ),
        )

    def log_camera(self, t_ns: int, color: npt.ArrayLike) -> None:
        """One colour frame (``/camera/color``); it clears the hand skeleton drawn over it."""
        rr = self.rr
        set_time(self.rec, int(t_ns), self.origin(int(t_ns)))
        self.rec.log(CAMERA_COLOR, rr.Image(np.asarray(color)))
        self.rec.log(f"{CAMERA_COLOR}/hand", rr.Clear(recursive=False))

    def log_hand_2d(self, t_ns: int, strips: Sequence[npt.ArrayLike]) -> None:
        """The hand skeleton found in the colour frame: line strips in pixels
        (``/camera/color/hand``)."""
        rr = self.rr
        set_time(self.rec, int(t_ns), self.origin(int(t_ns)))
        lines = [np.asarray(x, dtype=np.float64) for x in strips]
        self.rec.log(f"{CAMERA_COLOR}/hand", rr.LineStrips2D(lines, colors=(230, 80, 60)))

    def log_message(self, msg: Any) -> None:
        """Log a :class:`lfd.io.LiveMessage`: hand keypoints, object poses, ground-truth labels
        (other kinds are ignored)."""
        side = getattr(msg, "side", None)
        if msg.kind == "hand":
            self.log_hand(msg.t_ns, msg.value, side=side)
        elif msg.kind == "object":
            pose = msg.value
            self.log_object(pose.name, msg.t_ns, pose.position, pose.quaternion)
        elif msg.kind == "label":
            hand = getattr(msg.value, "hand", None) or side
            self.log_skill(msg.value, source="ground_truth", side=hand)

    # --- features --------------------------------------------------------------------------------
    def log_samples(
        self,
        t_ns: npt.ArrayLike,
        values: npt.ArrayLike,
        thresholds: npt.ArrayLike | None = None,
        *,
        target: npt.ArrayLike | None = None,
        frame: npt.ArrayLike | None = None,
    ) -> None:
        """Feature rows as they are computed: ``values`` (n, f), ``t_ns`` (n,), ``frame`` the
        rows' sample indices (default: continuing from the rows logged before)."""
        t = np.atleast_1d(np.asarray(t_ns))
        vals = np.asarray(values, dtype=np.float64)
        if vals.ndim == 1:
            vals = vals[None, :]
        n = vals.shape[0]
        frames = np.arange(self.samples, self.samples + n) if frame is None else frame
        if t.size:
            self.origin(int(np.min(t)))
        log_feature_arrays(
            self.feature_names,
            vals,
            thresholds,
            t,
            target=None if target is None else np.atleast_1d(np.asarray(target)),
            object_names=self.object_names,
            frame=frames,
            recording=self.rec,
            origin_ns=self._origin,
        )
        self.samples += n

    def log_sample(
        self,
        t_ns: int,
        values: npt.ArrayLike,
        thresholds: npt.ArrayLike | None = None,
        *,
        target: int | None = None,
    ) -> None:
        """One feature row, shape (f,) (see :meth:`log_samples`)."""
        thr = None if thresholds is None else np.asarray(thresholds, dtype=np.float64)[None, :]
        self.log_samples(
            [int(t_ns)],
            np.asarray(values, dtype=np.float64)[None, :],
            thr,
            target=None if target is None else [target],
        )

    # --- segmentation ----------------------------------------------------------------------------
    def log_section(self, t_ns: int, frame: int | None = None) -> None:
        """A stage-1 section that starts at ``t_ns`` (the first call: the first section)."""
        rr = self.rr
        k = self._sections
        self._sections += 1
        names = [f"section {i}" for i in range(self._sections)]
        colors = [_rgba(SECTION_COLORS[i % 2]) for i in range(self._sections)]
        self.rec.log(
            SECTIONS,
            rr.StateConfiguration(values=names, colors=np.array(colors, dtype=np.uint32)),
            static=True,
        )
        self.rec.send_columns(
            SECTIONS,
            indexes=self._cols([t_ns], None if frame is None else [frame]),
            columns=rr.StateChange.columns(state=[f"section {k}"]),
        )

    def _state(
        self, source: str, seg: SegmentLike | None, t_ns: int, side: str | None = None
    ) -> None:
        """Set lane ``source`` (of the ``side`` hand, of two) to ``seg``'s state from ``t_ns``
        (None: an empty gap)."""
        rr = self.rr
        path = hand_lane(self._side(side), source)
        values = self._lanes.setdefault(path, {})
        state = ""
        if seg is not None:
            obj = getattr(seg, "object", None)
            state = skill_state(seg.skill, obj)
            if state not in values:
                label = seg.skill + (f" {obj}" if obj else "")
                values[state] = (label, _rgba(SKILL_COLORS.get(seg.skill, UNKNOWN_COLOR)))
                self.rec.log(
                    path,
                    rr.StateConfiguration(
                        values=list(values),
                        labels=[v[0] for v in values.values()],
                        colors=np.array([v[1] for v in values.values()], dtype=np.uint32),
                    ),
                    static=True,
                )
        self.rec.send_columns(
            path, indexes=self._cols([t_ns]), columns=rr.StateChange.columns(state=[state])
        )

    def log_skill(
        self, segment: SegmentLike, *, source: str = "result", side: str | None = None
    ) -> None:
        """A settled skill span (``skill``, ``start_ns``, ``end_ns``, optional ``object``) in
        lane ``source`` (of the ``side`` hand, of two); a later span starting where it ends
        replaces its end."""
        if int(segment.end_ns) < int(segment.start_ns):
            raise DemonstrationError(f"segment {segment.skill!r} ends before it starts")
        self._state(source, segment, int(segment.start_ns), side)
        self._state(source, None, int(segment.end_ns), side)

    def log_provisional(
        self, segment: SegmentLike | None, t_ns: int | None = None, *, side: str | None = None
    ) -> None:
        """The open span as the live segmenter sees it now (None: none), in lane
        ``provisional`` (of the ``side`` hand, of two) from its start (or from ``t_ns`` when
        clearing it)."""
        if segment is None:
            if t_ns is not None:
                self._state(PROVISIONAL, None, int(t_ns), side)
            return
        self._state(PROVISIONAL, segment, int(segment.start_ns), side)

    def log_handovers(self, handovers: Sequence[Any]) -> None:
        """Handovers a live segmenter settled (:class:`lfd.Handover`): added to the lane
        ``/segmentation/handovers/result`` and the points of ``/world/handovers/result`` (where
        the object was at the giver's release, from the poses logged)."""
        if not handovers:
            return
        for h in handovers:
            self._handovers.append(h)
            self._handover_points.append(self._object_at(h.object, int(h.end_ns)))
        log_handovers(
            self._handovers,
            source="result",
            positions=self._handover_points,
            recording=self.rec,
            origin_ns=self.origin(int(self._handovers[0].start_ns)),
        )

    def _object_at(self, name: str | None, t_ns: int) -> np.ndarray | None:
        """The logged position of object ``name`` nearest ``t_ns`` (None: none kept)."""
        poses = self._poses.get(name) if name is not None else None
        if not poses:
            return None
        return min(poses, key=lambda tp: abs(tp[0] - t_ns))[1]

    def log_update(
        self, update: Any, provisional: SegmentLike | Mapping[str, SegmentLike] | None = None
    ) -> None:
        """What one step of a live segmenter produced (a
        :class:`~lfd.segmentation.live.LiveUpdate`: feature ``rows``, new ``sections``, settled
        ``segments``) and the provisional span, if any. Of both hands (a
        :class:`~lfd.segmentation.live_hands.HandsUpdate`: a ``LiveUpdate`` per hand, settled
        ``handovers``), each hand's in its lanes and ``provisional`` by side."""
        lanes = getattr(update, "lanes", None)
        if lanes is not None:
            spans = provisional if isinstance(provisional, Mapping) else {}
            for side, lane in lanes.items():
                if not self.two_hands:  # one hand: as a one-hand update
                    self.log_update(lane, spans.get(side, lane.provisional))
                    continue
                for s in lane.segments:
                    self.log_skill(s, side=side)
                span = spans.get(side, lane.provisional)
                if span is not None:
                    self.log_provisional(span, side=side)
            self.log_handovers(update.handovers)
            return
        if isinstance(provisional, Mapping):
            provisional = next(iter(provisional.values()), None)
        rows = update.rows
        if rows:
            self.log_samples(
                [r.t_ns for r in rows],
                np.stack([r.values for r in rows]),
                np.stack([r.thresholds for r in rows]),
                target=[r.target for r in rows],
            )
        for t in update.sections:
            self.log_section(t)
        for s in update.segments:
            self.log_skill(s)
        if provisional is not None:
            self.log_provisional(provisional)

    def log_score(self, skill: str, t_ns: int, score: float) -> None:
        """A stage-2 score of ``skill`` at ``t_ns`` (``/segmentation/greedy/scores/<skill>``)."""
        rr = self.rr
        path = f"{GREEDY}/scores/{skill}"
        color = SKILL_COLORS.get(skill, UNKNOWN_COLOR)
        self.rec.log(
            path, rr.SeriesPoints(names=skill, colors=[color], marker_sizes=4.0), static=True
        )
        y = float(score) if np.isfinite(score) else np.nan
        self.rec.send_columns(
            path, indexes=self._cols([t_ns]), columns=rr.Scalars.columns(scalars=[y])
        )

    def log_text(self, t_ns: int, text: str, *, level: str = "WARN", path: str = WARNINGS) -> None:
        """A message on the demonstration's timeline (warnings by default)."""
        self.rec.send_columns(
            path,
            indexes=self._cols([t_ns]),
            columns=self.rr.TextLog.columns(text=[text], level=[level]),
        )

    def flush(self) -> None:
        """Send what was logged to every sink now."""
        self.rec.flush()
