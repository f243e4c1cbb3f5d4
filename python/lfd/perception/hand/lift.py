"""Lift 2-D hand keypoints to metric 3-D with an aligned depth image.

A colour hand-landmark model (MediaPipe Hands) gives 21 keypoints in pixels and a relative depth
per keypoint (same pixel scale as u, v; wrist ~ 0; larger = farther). The depth camera gives the
distance to the nearest surface at every pixel. :func:`lift_keypoints` combines the two:

1. Per keypoint, the depth pixels of a small square patch around (u, v) (clipped to the image),
   without missing pixels (0) and pixels of ``exclude`` (known objects).
2. A hand reference depth: every patch pixel votes for the wrist depth (its depth, plus the
   keypoint's surface-to-centre offset, minus the keypoint's relative depth in metres). The
   reference is the depth most keypoints agree on (:func:`_reference`; palm keypoints weigh
   :data:`PALM_WEIGHT`), penalised where the camera would see through a keypoint: a forearm
   over the palm, the table or an object beside the fingers are outvoted.
3. The expected depth of every keypoint is the reference plus its relative depth (pixels times
   the hand depth / fx). Patch pixels more than a tolerance (:data:`FIRST_PASS_TOL`) in front
   of or behind the keypoint's expected skin are dropped (another finger or an object in front
   of it, background beside it); the median of the rest is the measured skin depth.
4. The reference and the scale of the relative depth are fitted to the measured keypoints (the
   landmark model's z is only roughly in pixel units), and step 3 is repeated around the fit
   with tolerances from its residual spread (:data:`NEAR_SPREADS`, :data:`FAR_SPREADS`): tight
   when the landmark model's z agrees with the depth, looser when it does not.
5. Keypoints left with fewer than :data:`MIN_PIXEL_FRACTION` of their patch are hidden
   (occluded, no depth, or off the hand): their depth is the expected depth of the final fit
   (``visible`` False, lower confidence).

Depth measures the skin, keypoints are joint centres: each measured surface point is moved
along its viewing ray by the keypoint's :data:`JOINT_RADIUS`.

Pixel convention: (0, 0) is the centre of the top-left pixel, as in OpenCV and
:meth:`lfd.sim.scene.CameraSpec.intrinsics` (principal point ``(W - 1) / 2``). Landmarks
normalised to [0, 1] by the image size (MediaPipe) convert as ``u = x W - 0.5``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import LfdError

N_KEYPOINTS = 21
PALM: tuple[int, ...] = (0, 5, 9, 13, 17)
"""Wrist and the four finger MCPs: the keypoints that weigh most in the hand reference depth."""

JOINT_RADIUS = np.array(
    [
        0.020,  # 0 wrist: half the wrist's thickness (adult wrist ~40 mm dorso-palmar)
        0.016,  # 1 thumb CMC: deep in the thenar eminence
        0.010,  # 2 thumb MCP
        0.009,  # 3 thumb IP
        0.0065,  # 4 thumb tip
        *(0.011, 0.009, 0.0075, 0.0065) * 4,  # index .. pinky: MCP (knuckle), PIP, DIP, tip
    ]
)
"""Distance (m) from the skin seen by the camera to each keypoint (MediaPipe order), for an
adult hand: about half the thickness of the hand at that joint. The measured surface is moved
this far along the viewing ray. Fingertips are thinnest, the palm and wrist thickest. (The
simulator's capsule hand, :mod:`lfd.sim.hand`, has a thicker wrist, 24 mm, and its thumb CMC
~27 mm under the back of the palm, so lifting its wrist and CMC comes out ~4 mm short.)"""

NEAR_SPREADS = 1.5
NEAR_RANGE = (0.008, 0.02)
"""Patch pixels more than ``NEAR_SPREADS`` residual spreads (within ``NEAR_RANGE``, m) in front
of the expected surface are not the keypoint's own skin (an object or a finger over it)."""
FAR_SPREADS = 2.5
FAR_RANGE = (0.012, 0.03)
"""Patch pixels more than ``FAR_SPREADS`` residual spreads (within ``FAR_RANGE``, m) behind the
expected surface are background."""
DEFAULT_SPREAD = 0.008
"""Residual spread (m) assumed when too few keypoints are measured to estimate it."""
MIN_SPREAD = 0.003
MIN_FIT_SPAN = 0.02
"""The scale of the relative depth is fitted only when the measured keypoints span this (m)."""
FIRST_PASS_TOL = (0.02, 0.03)
"""Tolerances (m, in front / behind) of the first pass, before the relative depth is fitted to
the hand (its scale taken as given)."""
VOTE_WINDOW = 0.03
"""Width (m) of the window of reference votes with the most weight."""
BEHIND_PENALTY = 0.5
"""Weight of the pixels behind a candidate reference depth against it (see :func:`_reference`)."""
PALM_WEIGHT = 1.5
"""Weight of a palm keypoint's votes for the reference (a finger keypoint's: 1)."""
MIN_PIXEL_FRACTION = 0.15
"""A keypoint is measured when at least this fraction of its patch (and 3 pixels) is hand."""
PATCH_FRACTION = 0.06
"""Default patch half-size as a fraction of the palm length in pixels (wrist to the MCPs,
relative z included): ~5 px for a hand at 0.7 m with fx = 615, narrower than a finger."""
PATCH_RANGE = (1, 12)
"""Bounds of the default patch half-size (pixels)."""
SCALE_RANGE = (0.6, 1.6)
"""Bounds of the relative-depth scale fitted to the measured keypoints."""
FILLED_CONFIDENCE = 0.5
"""Confidence of a keypoint filled from relative depth (times the presence score), when at least
:data:`FULL_SUPPORT` keypoints are measured (less with fewer). Above preprocessing's default
threshold (``MIN_KEYPOINT_CONFIDENCE``, 0.3): a fingertip hidden behind the grasped object is an
estimate (7 mm mean error on renders), down-weighted, not a missing sample."""
FULL_SUPPORT = 6


@dataclass
class LiftedHand:
    """21 hand keypoints in metres in the camera frame (OpenCV: x right, y down, z forward).

    Attributes
    ----------
    points : np.ndarray
        (21, 3) joint centres (m), camera frame.
    visible : np.ndarray
        (21,) bool: the keypoint's depth was measured on the hand (else filled from the landmark
        model's relative depth).
    confidence : np.ndarray
        (21,) in [0, 1], times the hand presence score: a measured keypoint 0.6 + 0.4 f, f the
        fraction of hand pixels in its patch (1 from half the patch on); a filled one
        :data:`FILLED_CONFIDENCE` (less when fewer than :data:`FULL_SUPPORT` are measured).
    """

    points: np.ndarray
    visible: np.ndarray
    confidence: np.ndarray

    def to_world(self, world_T_camera: np.ndarray) -> np.ndarray:
        """The keypoints (21, 3) in the frame of the pose ``world_T_camera`` (4, 4)."""
        T = np.asarray(world_T_camera, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise LfdError(f"world_T_camera must be a finite 4x4 matrix, got shape {T.shape}")
        return np.asarray(self.points @ T[:3, :3].T + T[:3, 3])


def _check_inputs(
    keypoints_2d: np.ndarray,
    relative_z: np.ndarray,
    depth_mm: np.ndarray,
    K: np.ndarray,
    exclude: np.ndarray | None,
    score: float,
    patch_px: int | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    kp = np.asarray(keypoints_2d)
    if kp.shape != (N_KEYPOINTS, 2) or kp.dtype.kind not in "iuf":
        raise LfdError(f"keypoints_2d must be a (21, 2) array of pixels, got shape {kp.shape}")
    if not np.all(np.isfinite(kp)):
        raise LfdError("keypoints_2d contains NaN or infinite values")
    rz = np.asarray(relative_z)
    if rz.shape != (N_KEYPOINTS,) or rz.dtype.kind not in "iuf":
        raise LfdError(f"relative_z must be a (21,) array, got shape {rz.shape}")
    if not np.all(np.isfinite(rz)):
        raise LfdError("relative_z contains NaN or infinite values")
    depth = np.asarray(depth_mm)
    if depth.ndim != 2 or depth.shape[0] < 1 or depth.shape[1] < 1 or depth.dtype.kind not in "iuf":
        raise LfdError(
            f"depth_mm must be an (H, W) image of millimetres, got shape {depth.shape}"
            f" and dtype {depth.dtype}"
        )
    Km = np.asarray(K)
    if Km.shape != (3, 3) or Km.dtype.kind not in "iuf":
        raise LfdError(f"K must be a 3x3 intrinsic matrix, got shape {Km.shape}")
    Km = Km.astype(float)
    if not np.all(np.isfinite(Km)):
        raise LfdError("K contains NaN or infinite values")
    if Km[0, 0] <= 0 or Km[1, 1] <= 0 or not np.allclose(Km[2], (0.0, 0.0, 1.0)):
        raise LfdError("K must have positive focal lengths and a last row (0, 0, 1)")
    ex = None
    if exclude is not None:
        ex = np.asarray(exclude)
        if ex.shape != depth.shape:
            raise LfdError(
                f"exclude must have the depth image's shape {depth.shape}, got {ex.shape}"
            )
        ex = ex.astype(bool, copy=False)
    if not np.isfinite(score) or not 0.0 <= score <= 1.0:
        raise LfdError(f"score must be in [0, 1], got {score}")
    if patch_px is not None and (int(patch_px) != patch_px or patch_px < 0):
        raise LfdError(f"patch_px must be a non-negative integer, got {patch_px}")
    return kp.astype(float), rz.astype(float), depth, Km, ex


def default_patch_px(keypoints_2d: np.ndarray, relative_z: np.ndarray) -> int:
    """Patch half-size (pixels) for a hand: :data:`PATCH_FRACTION` of its palm length.

    The palm length is the median distance from the wrist to the four finger MCPs in
    (u, v, relative z), so a palm seen edge-on is not taken for a small hand.
    """
    p = np.column_stack([keypoints_2d, relative_z])
    length = float(np.median(np.linalg.norm(p[list(PALM[1:])] - p[0], axis=1)))
    return int(np.clip(round(PATCH_FRACTION * length), *PATCH_RANGE))


def _patches(
    depth: np.ndarray, exclude: np.ndarray | None, kp: np.ndarray, half: int
) -> np.ndarray:
    """Depth (m) of the (2 half + 1)^2 pixels around every keypoint, (21, P); NaN where missing,
    excluded or outside the image."""
    H, W = depth.shape
    off = np.arange(-half, half + 1)
    cols = np.rint(kp[:, 0]).astype(np.int64)[:, None] + off
    rows = np.rint(kp[:, 1]).astype(np.int64)[:, None] + off
    inside = ((rows >= 0) & (rows < H))[:, :, None] & ((cols >= 0) & (cols < W))[:, None, :]
    r = np.clip(rows, 0, H - 1)[:, :, None]
    c = np.clip(cols, 0, W - 1)[:, None, :]
    z = depth[r, c].astype(float)
    ok = inside & np.isfinite(z) & (z > 0)
    if exclude is not None:
        ok &= ~exclude[r, c]
    return np.where(ok, z * 1e-3, np.nan).reshape(len(kp), -1)


def _reference(votes: np.ndarray, weight: np.ndarray, window: float) -> float | None:
    """The wrist depth the patches agree on best; None without votes.

    ``votes`` (21, P) are the pixels' depths converted to wrist depths (NaN: no pixel),
    ``weight`` (21,) each keypoint's weight. A candidate depth is scored by, per keypoint, the
    fraction of its pixels within ``window`` of it (the keypoint's skin where the candidate
    expects it) minus :data:`BEHIND_PENALTY` times the fraction farther behind (the camera would
    see through the keypoint: it cannot be there); pixels in front are an occluder and count
    neither way. Candidates are histogram bins of ``window`` / 4; the result is the weighted
    median of the votes in the best window (the nearest on ties).
    """
    ok = np.isfinite(votes)
    if not ok.any():
        return None
    n_bins_window = 4
    step = window / n_bins_window
    lo = float(np.min(votes[ok]))
    idx = np.where(ok, ((np.where(ok, votes, lo) - lo) / step).astype(np.int64), 0)
    nb = int(idx.max()) + 1 + n_bins_window
    rows = np.broadcast_to(np.arange(votes.shape[0])[:, None], votes.shape)
    hist = np.bincount((rows * nb + idx)[ok], minlength=votes.shape[0] * nb)
    hist = hist.reshape(votes.shape[0], nb).astype(float)
    count = np.maximum(ok.sum(axis=1), 1)[:, None]
    cum = np.concatenate([np.zeros((len(hist), 1)), np.cumsum(hist, axis=1)], axis=1) / count
    support = cum[:, n_bins_window:] - cum[:, :-n_bins_window]  # bins i .. i + 3
    behind = cum[:, -1:] - cum[:, n_bins_window:]
    score = weight @ (support - BEHIND_PENALTY * behind)
    i = int(np.argmax(score))
    inside = ok & (idx >= i) & (idx < i + n_bins_window)
    v = votes[inside]
    w = np.broadcast_to((weight[:, None] / count), votes.shape)[inside]
    order = np.argsort(v)
    cw = np.cumsum(w[order])
    return float(v[order][np.searchsorted(cw, 0.5 * cw[-1])])


def _measure(
    z: np.ndarray, surface: np.ndarray, tol_near: float, tol_far: float, min_px: int
) -> tuple[np.ndarray, np.ndarray]:
    """Median surface depth (21,) of the patch pixels within the tolerances of the expected
    surface (NaN with fewer than ``min_px``) and the pixel counts."""
    lo = (surface - tol_near)[:, None]
    hi = (surface + tol_far)[:, None]
    keep = (z >= lo) & (z <= hi)  # NaN compares False
    n = keep.sum(axis=1)
    srt = np.sort(np.where(keep, z, np.inf), axis=1)  # kept pixels first, in order
    i = np.arange(len(z))
    lo, hi = np.maximum(n - 1, 0) // 2, n // 2
    med = 0.5 * (srt[i, lo] + srt[i, np.minimum(hi, z.shape[1] - 1)])
    return np.where(n >= min_px, med, np.nan), n


def _fit_relative(
    centre: np.ndarray, offset: np.ndarray, z0: float, fit_scale: bool
) -> tuple[float, float, float]:
    """Fit ``centre ~ z0 + scale * offset`` over the measured keypoints (finite ``centre``).

    Returns the reference depth, the scale (1 when not fitted, or when the measured keypoints
    span less than :data:`MIN_FIT_SPAN` of relative depth) and the robust spread (m) of the
    residuals (1.4826 MAD; NaN with fewer than 4 keypoints). One refit without the keypoints
    beyond 3 spreads (an occluder measured instead of the joint).
    """
    ok = np.isfinite(centre)
    m, o = centre[ok], offset[ok]
    if m.size == 0:
        return z0, 1.0, float("nan")
    scale = 1.0
    keep = np.ones(m.size, bool)
    spread = float("nan")
    for _ in range(2):
        mk, ok_ = m[keep], o[keep]
        if fit_scale and mk.size >= 5 and np.ptp(ok_) >= MIN_FIT_SPAN:
            do = ok_ - ok_.mean()
            slope = float(do @ (mk - mk.mean()) / (do @ do))
            scale = float(np.clip(slope, *SCALE_RANGE))
        z0 = float(np.median(mk - scale * ok_))
        res = m - z0 - scale * o
        if m.size >= 4:
            spread = float(1.4826 * np.median(np.abs(res - np.median(res[keep]))))
            keep = np.abs(res) < 3.0 * max(spread, MIN_SPREAD)
            if keep.sum() < 4:
                break
    return z0, scale, spread


def lift_keypoints(
    keypoints_2d: np.ndarray,
    relative_z: np.ndarray,
    depth_mm: np.ndarray,
    K: np.ndarray,
    *,
    exclude: np.ndarray | None = None,
    score: float = 1.0,
    patch_px: int | None = None,
    radius: np.ndarray | None = None,
    tol_near: float | None = None,
    tol_far: float | None = None,
    fit_scale: bool = True,
) -> LiftedHand | None:
    """Lift 21 hand keypoints (pixels + relative depth) to metres with an aligned depth image.

    Parameters
    ----------
    keypoints_2d : np.ndarray
        (21, 2) pixels (u, v) from the top-left pixel's centre, MediaPipe-21 order.
    relative_z : np.ndarray
        (21,) the landmark model's relative depth in pixel units (same scale as u, v; larger =
        farther; wrist ~ 0).
    depth_mm : np.ndarray
        (H, W) depth along the optical axis in millimetres (0 = no data), aligned to the colour
        image the keypoints come from.
    K : np.ndarray
        (3, 3) intrinsics of that image.
    exclude : np.ndarray, optional
        (H, W) bool, pixels known not to be the hand (tagged objects); their depth is ignored.
    score : float
        Hand presence score in [0, 1]; scales the confidences.
    patch_px : int, optional
        Half-size of the square depth patch per keypoint (default :func:`default_patch_px`).
    radius : np.ndarray, optional
        (21,) skin-to-joint-centre distances (m), default :data:`JOINT_RADIUS`.
    tol_near, tol_far : float, optional
        How far (m) in front of / behind the expected skin depth a patch pixel may be (default:
        from the spread of the measured keypoints around the relative depth, see
        :data:`NEAR_SPREADS`, :data:`FAR_SPREADS`).
    fit_scale : bool
        Fit the relative depth's scale to the measured keypoints (else it is taken as given).

    Returns
    -------
    LiftedHand or None
        None when no keypoint has hand depth (no valid pixels, or none consistent with a hand).

    Raises
    ------
    LfdError
        Wrong shapes, a depth image of the wrong size, non-finite values in K or the keypoints.
    """
    kp, rz, depth, Km, ex = _check_inputs(
        keypoints_2d, relative_z, depth_mm, K, exclude, score, patch_px
    )
    rad = JOINT_RADIUS if radius is None else np.asarray(radius, dtype=float)
    if rad.shape != (N_KEYPOINTS,) or not np.all(np.isfinite(rad)):
        raise LfdError(f"radius must be a finite (21,) array, got shape {rad.shape}")
    half = default_patch_px(kp, rz) if patch_px is None else int(patch_px)
    z = _patches(depth, ex, kp, half)
    palm = list(PALM)
    have = np.isfinite(z)
    if not have.any():
        return None

    rays = np.linalg.solve(Km, np.column_stack([kp, np.ones(N_KEYPOINTS)]).T).T
    rays /= rays[:, 2:3]
    cos = 1.0 / np.linalg.norm(rays, axis=1)
    r_z = rad * cos  # surface-to-centre offset along the ray, in depth (z)
    fx = float(Km[0, 0])

    # Reference: every patch pixel votes for the wrist's centre depth; each keypoint's votes
    # weigh 1 in all (the palm's PALM_WEIGHT), so the depth most keypoints agree on wins, not
    # a large surface (an occluding forearm, the background) behind or over a few of them.
    z_hand = float(np.nanmedian(z[palm] if have[palm].any() else z))
    offset = rz * (z_hand / fx)
    votes = z + (r_z - offset)[:, None]
    joint_w = np.where(np.isin(np.arange(N_KEYPOINTS), palm), PALM_WEIGHT, 1.0)
    z_ref = _reference(votes, joint_w, VOTE_WINDOW)
    if z_ref is None:
        return None
    z0 = z_ref
    offset = rz * ((z0 + float(np.mean(offset[palm]))) / fx)

    min_px = max(3, int(np.ceil(MIN_PIXEL_FRACTION * z.shape[1])))
    min_px = min(min_px, z.shape[1])
    # First pass: wide tolerances around the initial reference; then fit the reference and
    # the scale of the relative depth to what was measured, and measure again with tolerances
    # from the fit's residuals (how well the landmark model's z agrees with the depth).
    surface, n = _measure(z, z0 + offset - r_z, *FIRST_PASS_TOL, min_px)
    z0, scale, spread = _fit_relative(surface + r_z, offset, z0, fit_scale)
    if not np.isfinite(spread):
        spread = DEFAULT_SPREAD
    near = float(np.clip(NEAR_SPREADS * spread, *NEAR_RANGE)) if tol_near is None else tol_near
    far = float(np.clip(FAR_SPREADS * spread, *FAR_RANGE)) if tol_far is None else tol_far
    surface, n = _measure(z, z0 + scale * offset - r_z, near, far, min_px)
    centre = surface + r_z
    visible = np.isfinite(centre)
    if not visible.any():
        return None
    z0, scale, _ = _fit_relative(centre, offset, z0, fit_scale)  # the filled follow this fit
    expected = z0 + scale * offset
    depth_z = np.where(visible, centre, expected)
    points = rays * depth_z[:, None]

    frac = np.minimum(1.0, n / (0.5 * z.shape[1]))
    support = min(1.0, visible.sum() / FULL_SUPPORT)
    conf = np.where(visible, 0.6 + 0.4 * frac, FILLED_CONFIDENCE * support) * float(score)
    return LiftedHand(points=points, visible=visible, confidence=np.clip(conf, 0.0, 1.0))


COLOUR_CONFIDENCE = 0.7
"""Confidence of a keypoint placed without depth (:func:`lift_from_colour`), before the hand
presence score and the fit's reprojection error scale it: below a measured one (0.6-1.0 times
the score) at best, as its distance rests on the landmark model's idea of the hand's size."""

COLOUR_FIT_PX = 8.0
"""A colour-only fit whose landmarks reproject this far off (RMS, pixels) halves the
confidence."""


def fixed_skeleton(world: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The hand ``world`` (21, 3) with its bones (:data:`lfd.demo.HAND_BONES`) set to
    ``lengths`` (21,): each bone keeps its direction, from the wrist out along each finger (the
    pinky's base hangs from the ring finger's, as the bones list it; the wrist-pinky bone is
    left to follow)."""
    from ...demo import HAND_BONES

    w = np.asarray(world, dtype=np.float64)
    out = w.copy()
    placed = {0}
    for k, (a, b) in enumerate(HAND_BONES):
        if b in placed:  # a second bone to an already placed joint (wrist-pinky)
            continue
        d = w[b] - w[a]
        n = float(np.linalg.norm(d))
        out[b] = out[a] + (d / n * float(lengths[k]) if n > 0 else 0.0)
        placed.add(b)
    return out


def lift_from_colour(
    keypoints_2d: np.ndarray,
    world: np.ndarray,
    K: np.ndarray,
    *,
    score: float = 1.0,
    lengths: np.ndarray | None = None,
) -> LiftedHand | None:
    """Place the hand in metres from one colour image: MediaPipe's metric landmarks (``world``,
    (21, 3) around the hand's centre) moved and turned so that they project onto the image
    landmarks (``keypoints_2d``, (21, 2) pixels) through ``K``: the perspective-n-point fit
    MediaPipe's own 3-D demos use (``cv2.solvePnP``, SQPnP). The distance comes from the
    landmarks' metric size, so an unusually large or small hand is placed a little too near or
    too far. None when the fit puts the hand behind the camera or fails.

    ``lengths`` (21,), the user's bone lengths (:data:`lfd.demo.HAND_BONES` order), replace the
    landmark model's, whose metric hand changes size from frame to frame
    (:func:`fixed_skeleton`): the distance then follows the user's hand.

    Every keypoint is ``visible`` (seen in the image, no depth measured); its confidence is
    :data:`COLOUR_CONFIDENCE` times ``score`` times ``1 / (1 + rms / COLOUR_FIT_PX)``.
    """
    import cv2

    if lengths is not None:
        world = fixed_skeleton(world, lengths)
    uv = np.ascontiguousarray(keypoints_2d, dtype=np.float64).reshape(-1, 1, 2)
    xyz = np.ascontiguousarray(world, dtype=np.float64).reshape(-1, 1, 3)
    if uv.shape[0] != 21 or xyz.shape[0] != 21:
        raise LfdError(f"expected 21 landmarks, got {uv.shape[0]} and {xyz.shape[0]}")
    if not (np.isfinite(uv).all() and np.isfinite(xyz).all()):
        return None
    Kf = np.asarray(K, dtype=np.float64)
    ok, rvec, tvec = cv2.solvePnP(xyz, uv, Kf, None, flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        return None
    R, _ = cv2.Rodrigues(rvec)
    points = xyz.reshape(21, 3) @ R.T + tvec.reshape(3)
    if not (np.isfinite(points).all() and (points[:, 2] > 0).all()):
        return None
    proj, _ = cv2.projectPoints(xyz, rvec, tvec, Kf, None)
    rms = float(np.sqrt(np.mean(np.sum((proj - uv) ** 2, axis=-1))))
    conf = COLOUR_CONFIDENCE * float(np.clip(score, 0.0, 1.0)) / (1.0 + rms / COLOUR_FIT_PX)
    return LiftedHand(points, np.ones(21, dtype=bool), np.full(21, conf))
