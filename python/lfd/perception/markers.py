"""Object poses from ArUco tags in RGB-D frames, relative to the reference marker.

Each box carries an ArUco tag on its top face; a reference tag (id 0) lying on the table
defines the world frame (origin at its centre, Z up). Per frame:

1. detect the tags with :class:`cv2.aruco.ArucoDetector` (sub-pixel corner refinement);
2. estimate each tag's pose with ``cv2.solvePnP(..., SOLVEPNP_IPPE_SQUARE)``;
3. refine it from the depth image: the tag is planar, so a plane is fitted to the back-projected
   depth pixels inside the tag, and the four corner viewing rays are intersected with it. This
   fixes the range (the weak direction of a 30-50 px tag's PnP) and the tilt; the in-plane
   rotation comes from the refined corners. Without enough valid depth, the range alone is
   corrected along the viewing ray of the tag centre (median depth inside the tag), and without
   depth the PnP pose is kept (of a box tag's two mirrored solutions that fit its corners
   equally well, the upright one: :data:`AMBIGUITY_PX`);
4. express it in the reference frame and move from the tag to the box centre (half the box
   height below the tag, along the tag normal).

A tag that is not detected gives no pose (the frame is marked missing, nothing is invented).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..demo import k_problem, pose_problem
from ..errors import LfdError
from .camera_file import length_problem

DEFAULT_DICTIONARY = "DICT_4X4_50"
REFERENCE_TAG_ID = 0
REFERENCE_MARKER_SIZE = 0.10
"""Side of the reference marker's black square (m)."""
TAG_MARGIN = 0.08
"""White margin around a box tag, as a fraction of the top-face side (the simulator's tags)."""

_MIN_PLANE_POINTS = 25
REFERENCE_GATE_M = 0.01
REFERENCE_GATE_DEG = 2.0
"""Reference observations farther than this from the running estimate are rejected."""
SUPPORT_TOLERANCE_M = 0.005
"""Without depth, a box may sink this far into the table or overlap another box (m) before its
distance is corrected (:meth:`MarkerTracker._supported`): PnP's own error on a fully seen tag."""
AMBIGUITY_PX = 1.0
"""Without depth, a box tag's two planar PnP solutions (IPPE) whose reprojection errors (RMS,
px) differ by less than this are told apart by the table: the one whose normal is nearer the
world's up is kept (see :meth:`MarkerTracker.detect`)."""


@dataclass(frozen=True)
class TaggedBox:
    """A cuboid with an ArUco tag centred on its top face.

    ``tag_size`` is the side of the tag's black square (m); by default the top face's smaller
    side minus the white margin (:data:`TAG_MARGIN` on each side).
    """

    name: str
    tag_id: int
    size: tuple[float, float, float]
    tag_size: float | None = None

    @property
    def marker_side(self) -> float:
        if self.tag_size is not None:
            return float(self.tag_size)
        return float(min(self.size[0], self.size[1]) * (1.0 - 2.0 * TAG_MARGIN))


@dataclass(frozen=True)
class MarkerConfig:
    """What the tracker looks for: dictionary, reference marker and the tagged boxes."""

    boxes: tuple[TaggedBox, ...]
    dictionary: str = DEFAULT_DICTIONARY
    reference_id: int = REFERENCE_TAG_ID
    reference_size: float = REFERENCE_MARKER_SIZE
    use_depth: bool = True

    def __post_init__(self) -> None:
        ids = [b.tag_id for b in self.boxes]
        if len(set(ids)) != len(ids) or self.reference_id in ids:
            raise LfdError(f"tag ids must be distinct from each other and the reference: {ids}")
        for b in self.boxes:
            for v in (*b.size, b.marker_side):
                problem = length_problem(v, f"box {b.name!r}: sizes and tag side")
                if problem is not None:
                    raise LfdError(problem)
        problem = length_problem(self.reference_size, "reference marker size")
        if problem is not None:
            raise LfdError(problem)

    @classmethod
    def from_objects(cls, objects: Iterable[Any], **kwargs: Any) -> MarkerConfig:
        """From anything with ``name``, ``tag_id`` and ``size`` (ObjectSpec, ObjectTrack, dicts)."""
        boxes = []
        for o in objects:
            get = o.get if isinstance(o, Mapping) else lambda k, d=None, o=o: getattr(o, k, d)
            size = tuple(float(v) for v in np.asarray(get("size"), float).ravel())
            if len(size) != 3:
                raise LfdError(f"object {get('name')!r}: size must have 3 values")
            tag = get("tag_size", None)
            boxes.append(
                TaggedBox(
                    str(get("name")),
                    int(get("tag_id", -1)),
                    (size[0], size[1], size[2]),
                    None if tag is None else float(tag),
                )
            )
        return cls(boxes=tuple(boxes), **kwargs)


@dataclass
class TagPose:
    """A detected tag: id, corners (4, 2) px, camera_T_tag (4, 4) and how range was fixed."""

    tag_id: int
    corners: np.ndarray
    camera_T_tag: np.ndarray
    refined: str  # "plane", "range" or "pnp"


@dataclass
class FrameObjects:
    """Object poses in one frame (world = reference marker frame).

    ``poses[name] = (position (3,), quaternion (x, y, z, w))`` for every box seen; boxes not seen
    are absent. ``reference_seen`` tells whether the reference tag was in this frame.
    """

    poses: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    tags: list[TagPose] = field(default_factory=list)
    reference_seen: bool = False


def _footprints_overlap(
    c1: np.ndarray,
    R1: np.ndarray,
    h1: np.ndarray,
    c2: np.ndarray,
    R2: np.ndarray,
    h2: np.ndarray,
    tolerance: float,
) -> bool:
    """Whether two boxes' footprints on the table (centres ``c``, rotations ``R``, half sizes
    ``h``; each turned about the vertical by its x axis' heading) overlap by more than
    ``tolerance`` (m): a separating-axis test of two rectangles."""
    rects = []
    for c, R, h in ((c1, R1, h1), (c2, R2, h2)):
        a = np.arctan2(R[1, 0], R[0, 0])
        ux, uy = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
        rects.append((np.asarray(c[:2], float), ux, uy, float(h[0]), float(h[1])))
    d = rects[1][0] - rects[0][0]
    for _, ax, ay, _, _ in rects:
        for axis in (ax, ay):
            reach = sum(abs(hx * float(ux @ axis)) + abs(hy * float(uy @ axis))
                        for _, ux, uy, hx, hy in rects)  # fmt: skip
            if abs(float(d @ axis)) >= reach - tolerance:
                return False
    return True


def _pose(rvec: np.ndarray, tvec: np.ndarray) -> np.ndarray | None:
    """OpenCV's rotation vector and translation as a 4x4 pose; None when not finite (IPPE
    returns NaN for some exactly symmetric views)."""
    import cv2

    if not (np.isfinite(rvec).all() and np.isfinite(tvec).all()):
        return None
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(rvec)[0]
    T[:3, 3] = np.ravel(tvec)
    return T


def rotation_to_quat(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) -> quaternion (x, y, z, w)."""
    from scipy.spatial.transform import Rotation

    return np.asarray(Rotation.from_matrix(R).as_quat(), float)


def _square(side: float) -> np.ndarray:
    h = side / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def pixel_rays(K: np.ndarray, px: np.ndarray) -> np.ndarray:
    """Viewing rays (n, 3) with z = 1 through pixels ``px`` (n, 2) of a camera ``K``."""
    x = (px[:, 0] - K[0, 2]) / K[0, 0]
    y = (px[:, 1] - K[1, 2]) / K[1, 1]
    return np.column_stack([x, y, np.ones(len(px))])


def _centre_pixel(c: np.ndarray) -> np.ndarray:
    """Intersection of the quad's diagonals: the projection of a planar square's centre."""
    p1, p3, p2, p4 = c[0], c[2], c[1], c[3]
    d1, d2 = p3 - p1, p4 - p2
    A = np.column_stack([d1, -d2])
    if abs(np.linalg.det(A)) < 1e-9:
        return np.asarray(c.mean(axis=0))
    s = np.linalg.solve(A, p2 - p1)[0]
    return np.asarray(p1 + s * d1)


def _inside_pixels(corners: np.ndarray, shape: tuple[int, int], shrink: float) -> np.ndarray:
    """Integer pixel coordinates (n, 2) inside the quad shrunk towards its centre."""
    import cv2

    centre = corners.mean(axis=0)
    quad = centre + (corners - centre) * shrink
    mask = np.zeros(shape, np.uint8)
    cv2.fillConvexPoly(mask, np.round(quad * 16).astype(np.int32), 1, cv2.LINE_8, 4)
    v, u = np.nonzero(mask)
    return np.column_stack([u, v])


def refine_with_depth(
    K: np.ndarray, corners: np.ndarray, T: np.ndarray, depth_m: np.ndarray, side: float
) -> tuple[np.ndarray, str]:
    """Refine a tag pose ``T`` (4, 4, camera frame) from a depth image (H, W) in metres.

    ``side`` is the tag side (m): depths farther than ``0.75 side`` from the median (the hand
    or another object in front of the tag) are ignored.
    """
    px = _inside_pixels(corners, depth_m.shape, 0.85)
    if px.size == 0:
        return T, "pnp"
    z = depth_m[px[:, 1], px[:, 0]]
    ok = z > 0
    px, z = px[ok], z[ok]
    if z.size < 4:
        return T, "pnp"
    # reject the hand or another object in front of the tag: keep depths near the median
    med = float(np.median(z))
    near = np.abs(z - med) < 0.75 * side
    px, z = px[near], z[near]
    out = T.copy()
    if z.size >= _MIN_PLANE_POINTS:
        P = pixel_rays(K, px.astype(float)) * z[:, None]
        c = P.mean(axis=0)
        _, sv, vt = np.linalg.svd(P - c, full_matrices=False)
        n = vt[2]
        if n @ c > 0:
            n = -n  # normal towards the camera, like the tag's z axis
        rays = pixel_rays(K, corners)
        with np.errstate(divide="ignore", invalid="ignore"):
            Q = rays * ((n @ c) / (rays @ n))[:, None]  # corners on the plane
        sides = np.linalg.norm(Q - np.roll(Q, 1, axis=0), axis=1)
        # a flat patch whose corners span the tag's side: the plane, not the PnP rotation, is
        # trusted (a 30-50 px tag's IPPE solution can be tilted by 50-70 degrees, the
        # ambiguous mirror pose)
        square = bool(np.all(np.isfinite(sides)) and np.all(np.abs(sides / side - 1.0) < 0.2))
        if sv[2] / np.sqrt(z.size) < 0.003 and square:
            x = (Q[1] - Q[0]) + (Q[2] - Q[3])
            x -= n * (x @ n)
            x /= np.linalg.norm(x)
            ray_c = pixel_rays(K, _centre_pixel(corners)[None])[0]
            out[:3, :3] = np.column_stack([x, np.cross(n, x), n])
            out[:3, 3] = ray_c * ((n @ c) / (ray_c @ n))
            return out, "plane"
    ray_c = pixel_rays(K, _centre_pixel(corners)[None])[0]
    out[:3, 3] = ray_c * med
    return out, "range"


class MarkerTracker:
    """Detect tags and estimate box poses in the reference marker's frame, frame by frame.

    Parameters
    ----------
    config : MarkerConfig
        Dictionary, reference marker and boxes.
    K : array, shape (3, 3)
        Camera intrinsics (images are assumed undistorted).
    world_T_camera : array, shape (4, 4), optional
        Known (calibrated) camera pose in the reference frame; when given, it is kept and the
        reference tag is not needed.

    The camera is assumed static: the reference pose is averaged over the frames that see it
    (observations more than 1 cm / 2 deg from the running estimate are rejected as outliers), so
    later frames where the hand hides the reference marker still have a world frame.
    """

    def __init__(
        self,
        config: MarkerConfig,
        K: npt.ArrayLike,
        *,
        world_T_camera: npt.ArrayLike | None = None,
    ) -> None:
        import cv2

        name = config.dictionary
        if not name.startswith("DICT_") or not isinstance(getattr(cv2.aruco, name, None), int):
            raise LfdError(f"unknown ArUco dictionary {name!r}")
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
        count = int(dictionary.bytesList.shape[0])
        for box_name, tag_id in [("the reference", config.reference_id)] + [
            (repr(b.name), b.tag_id) for b in config.boxes
        ]:
            if not 0 <= tag_id < count:
                raise LfdError(
                    f"tag id {tag_id} of {box_name} is not in {name} (ids 0-{count - 1})"
                )
        problem = k_problem(K)
        if problem is None and world_T_camera is not None:
            problem = pose_problem(world_T_camera)
            problem = None if problem is None else f"world_T_camera {problem}"
        if problem is not None:
            raise LfdError(problem)
        self.config = config
        self.K = np.asarray(K, float).reshape(3, 3)
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        params.cornerRefinementWinSize = 3
        params.cornerRefinementMaxIterations = 50
        params.cornerRefinementMinAccuracy = 0.01
        self._detector = cv2.aruco.ArucoDetector(dictionary, params)
        self._sides = {b.tag_id: b.marker_side for b in config.boxes}
        self._sides[config.reference_id] = config.reference_size
        self._boxes = {b.tag_id: b for b in config.boxes}
        self._sizes = {b.name: b.size for b in config.boxes}
        self._last_box: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._ref_sum: np.ndarray | None = None
        self._ref_n = 0
        self.rejected_references = 0
        self._fixed_camera = world_T_camera is not None
        self.world_T_camera: np.ndarray | None = (
            None if world_T_camera is None else np.asarray(world_T_camera, float).reshape(4, 4)
        )

    def detect(self, color: np.ndarray, depth_mm: np.ndarray | None = None) -> list[TagPose]:
        """All known tags in one frame (colour (H, W, 3) RGB uint8, depth (H, W) uint16 mm)."""
        import cv2

        img = np.asarray(color)
        if img.ndim == 3:
            gray = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
        elif img.ndim == 2:
            gray = img
        else:
            raise LfdError(f"colour image must be (H, W, 3) or (H, W), got {img.shape}")
        if gray.dtype != np.uint8:
            raise LfdError(f"colour image must be uint8, got {gray.dtype}")
        depth_m = None
        if depth_mm is not None and self.config.use_depth:
            d = np.asarray(depth_mm)
            if d.shape != gray.shape:
                raise LfdError(f"depth shape {d.shape} differs from colour {gray.shape}")
            depth_m = d.astype(np.float64) * 1e-3
        corners, ids, _ = self._detector.detectMarkers(gray)
        out: list[TagPose] = []
        if ids is None:
            return out
        for c, i in zip(corners, ids.ravel(), strict=True):
            tag_id = int(i)
            if tag_id not in self._sides:
                continue
            c2 = np.asarray(c, float).reshape(4, 2)
            T = self._pnp(_square(self._sides[tag_id]), c2)
            if T is None:
                continue
            how = "pnp"
            if depth_m is not None:
                T, how = refine_with_depth(self.K, c2, T, depth_m, self._sides[tag_id])
            elif tag_id in self._boxes and self.world_T_camera is not None:
                T = self._upright(_square(self._sides[tag_id]), c2, T)
            out.append(TagPose(tag_id, c2, T, how))
        return out

    def _pnp(self, obj: np.ndarray, px: np.ndarray) -> np.ndarray | None:
        """Tag pose by IPPE_SQUARE; checked by reprojection, since OpenCV returns a zero rvec
        for rotations of exactly 180 degrees (a tag seen upside down, e.g. the reference), and
        NaN for some exactly symmetric views (the reference straight ahead, upside down): a
        non-finite solution is skipped."""
        import cv2

        best: tuple[float, np.ndarray] | None = None
        for flags in (cv2.SOLVEPNP_IPPE_SQUARE, cv2.SOLVEPNP_SQPNP):
            ok, rvec, tvec = cv2.solvePnP(obj, px, self.K, None, flags=flags)
            T = _pose(rvec, tvec) if ok else None
            if T is None:
                continue
            proj = cv2.projectPoints(obj, rvec, tvec, self.K, None)[0].reshape(-1, 2)
            err = float(np.abs(proj - px).max())
            if not np.isfinite(err):
                continue
            if best is None or err < best[0]:
                best = (err, T)
            if err < 1.0:
                break
        if best is None or best[0] > 5.0:
            return None
        return best[1]

    def _upright(self, obj: np.ndarray, px: np.ndarray, T: np.ndarray) -> np.ndarray:
        """Of a box tag's two planar PnP solutions (``cv2.solvePnPGeneric``, IPPE_SQUARE) that
        fit its corners within :data:`AMBIGUITY_PX` of each other, the one whose normal is
        nearer the world's up; ``T`` (the best fit) otherwise.

        A small tag's pose from colour alone is ambiguous: its corners fit two poses mirrored
        about the viewing ray almost equally well (on the simulator's renders, at 0.7 m, a 4 cm
        tag's solutions 1 and 58 degrees from upright fit within 0.1 px of each other, and the
        better fit is the wrong one when the hand covers part of the tag). The tilted one also
        moves the box centre, half the box height below the tag along its normal, by
        centimetres. Boxes stand on the table or on each other, so the upright one is taken;
        a box really held tilted is told apart by its corners whenever the fit can (its
        mirror fits worse by more than :data:`AMBIGUITY_PX`). Depth removes the ambiguity
        (:func:`refine_with_depth`), so this is for colour alone."""
        import cv2

        assert self.world_T_camera is not None
        up = self.world_T_camera[2, :3]  # the world's z axis in the camera frame
        try:
            n, rvecs, tvecs, errs = cv2.solvePnPGeneric(
                obj, px, self.K, None, flags=cv2.SOLVEPNP_IPPE_SQUARE
            )
        except cv2.error:
            return T
        cands = []
        for rvec, tvec, err in zip(rvecs[:n], tvecs[:n], np.ravel(errs)[:n], strict=True):
            S = _pose(rvec, tvec)
            if S is not None and np.isfinite(err):
                cands.append((float(err), S))
        if len(cands) < 2:
            return T
        best = min(e for e, _ in cands)
        near = [S for e, S in cands if e <= best + AMBIGUITY_PX]
        if len(near) < 2:
            return T
        return max(near, key=lambda S: float(S[:3, 2] @ up))

    def _update_reference(self, camera_T_ref: np.ndarray) -> None:
        if self._fixed_camera:
            return
        # the camera is static: an observation far from the current estimate (a hand over the
        # reference tag spoiling the depth refinement) is an outlier, not a camera motion
        if self.world_T_camera is not None and self._ref_n > 0:
            current = np.linalg.inv(self.world_T_camera)
            dt = np.linalg.norm(camera_T_ref[:3, 3] - current[:3, 3])
            cos = (np.trace(camera_T_ref[:3, :3].T @ current[:3, :3]) - 1.0) / 2.0
            if dt > REFERENCE_GATE_M or cos < np.cos(np.deg2rad(REFERENCE_GATE_DEG)):
                self.rejected_references += 1
                return
        # average the rotation (chordal mean, re-orthonormalised) and translation
        self._ref_sum = (
            camera_T_ref.copy() if self._ref_sum is None else self._ref_sum + camera_T_ref
        )
        self._ref_n += 1
        M = self._ref_sum / self._ref_n
        u, _, vt = np.linalg.svd(M[:3, :3])
        R = u @ vt
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = M[:3, 3]
        self.world_T_camera = np.linalg.inv(T)

    def process(self, color: np.ndarray, depth_mm: np.ndarray | None = None) -> FrameObjects:
        """Box poses in the reference frame for one frame."""
        tags = self.detect(color, depth_mm)
        result = FrameObjects(tags=tags)
        for tag in tags:
            if tag.tag_id == self.config.reference_id:
                self._update_reference(tag.camera_T_tag)
                result.reference_seen = True
        if self.world_T_camera is None:
            return result
        for tag in tags:
            box = self._boxes.get(tag.tag_id)
            if box is None:
                continue
            camera_T_tag = tag.camera_T_tag
            if tag.refined == "pnp":  # colour alone: its range is the weak direction
                camera_T_tag = self._supported(box, camera_T_tag)
            W = self.world_T_camera @ camera_T_tag
            R = W[:3, :3]
            centre = W[:3, 3] - R[:, 2] * (box.size[2] / 2.0)
            result.poses[box.name] = (centre, rotation_to_quat(R))
            self._last_box[box.name] = (centre, R)
        return result

    def _supported(self, box: TaggedBox, camera_T_tag: np.ndarray) -> np.ndarray:
        """``camera_T_tag`` moved along the tag centre's viewing ray towards the camera, the
        least that makes the box physically possible: not below the table (world ``z = 0``)
        and not inside another box (at its last pose); unchanged when it is possible already.

        From colour alone a box tag's distance is its weak direction: when the hand covers part
        of the tag, the detected square is smaller than the tag and PnP puts the box farther
        along the ray, on the simulator's renders up to 15 cm (never nearer), which sinks it into
        the table or into the box it stands on. The image position of the tag is kept (the
        viewing ray is well measured), only the distance is changed, and only for a pose that
        cannot be: a lifted box, or one standing behind another, is left where PnP puts it.
        The candidates are the distances at which the box stands on the table or on another
        box's top face; the farthest possible one is taken."""
        assert self.world_T_camera is not None
        ray = self.world_T_camera[:3, :3] @ camera_T_tag[:3, 3]  # camera to tag, world axes
        origin = self.world_T_camera[:3, 3]
        if ray[2] >= 0.0:  # looking up at the tag: moving nearer does not raise it
            return camera_T_tag
        R = self.world_T_camera[:3, :3] @ camera_T_tag[:3, :3]
        half = np.asarray(box.size, float) / 2.0
        # the lowest corner below the tag centre (world z), the tag being on the top face
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
        drop = float(-((signs * half + [0.0, 0.0, -half[2]]) @ R.T)[:, 2].min())
        others = [
            (c, Ro, np.asarray(self._sizes[n], float) / 2.0)
            for n, (c, Ro) in self._last_box.items()
            if n != box.name
        ]

        def possible(s: float) -> bool:
            tag = origin + s * ray
            bottom = tag[2] - drop
            if bottom < -SUPPORT_TOLERANCE_M:
                return False
            centre = tag - R[:, 2] * half[2]
            for c, Ro, h in others:
                if bottom > c[2] + h[2] - SUPPORT_TOLERANCE_M or tag[2] < c[2] - h[2]:
                    continue  # above it, or below its bottom
                if _footprints_overlap(centre, R, half, c, Ro, h, SUPPORT_TOLERANCE_M):
                    return False
            return True

        if possible(1.0):
            return camera_T_tag
        tops = [0.0] + [float(c[2] + h[2]) for c, _, h in others]
        scales = sorted(((t + drop - origin[2]) / ray[2] for t in tops), reverse=True)
        for s in scales:
            if 0.0 < s < 1.0 and possible(s):
                out = camera_T_tag.copy()
                out[:3, 3] = camera_T_tag[:3, 3] * s
                return out
        return camera_T_tag
