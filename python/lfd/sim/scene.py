"""The simulated workspace as MJCF: table, reference marker, AR-tagged boxes, hand and camera.

World frame = the reference marker (ArUco DICT_4X4_50 id 0) lying on the table: origin at the
marker centre, Z up, table surface at z = 0. The demonstrator stands at the -y edge of the table
and reaches towards +y; the camera looks at the workspace from across the table, like the
paper's RGB-D sensor on a tripod (0.8 m from the workspace, 640x480, fx = fy = 615 px).

Each box carries its tag on the top face, printed with a white margin; the tag's image x axis
(top-left -> top-right corner) is the box's +x axis and the image "up" is the box's +y axis, so
an OpenCV marker pose (x right, y up, z out of the marker) has the box's orientation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .hand import hand_mjcf

REFERENCE_TAG_ID = 0
REFERENCE_MARKER_SIZE = 0.10
"""Side of the reference marker's black square (m)."""

WORKSPACE_X = (-0.20, 0.20)
WORKSPACE_Y = (0.14, 0.36)
"""Region of the table where objects are placed (m, world frame)."""

DEMONSTRATOR_SHOULDER = np.array([0.12, -0.42, 0.30])
"""Approximate right shoulder of the demonstrator; the forearm points from here to the hand."""

LEFT_SHOULDER = DEMONSTRATOR_SHOULDER * np.array([-1.0, 1.0, 1.0])
"""The demonstrator's left shoulder (the right one mirrored about x = 0)."""

FOREARM_LENGTH = 0.26
"""Visible length of the forearm (for rendering and occlusion only; it has no keypoints)."""

TAG_MARGIN = 0.08
"""White margin around a box tag, as a fraction of the top-face side."""


@dataclass(frozen=True)
class ObjectSpec:
    """An AR-tagged cuboid: name, tag id, size (x, y, z) in metres and display colour."""

    name: str
    tag_id: int
    size: tuple[float, float, float]
    rgba: tuple[float, float, float, float] = (0.2, 0.35, 0.75, 1.0)


DEFAULT_OBJECTS: tuple[ObjectSpec, ...] = (
    ObjectSpec("box_1", 1, (0.05, 0.05, 0.05), (0.80, 0.22, 0.18, 1.0)),
    ObjectSpec("box_2", 2, (0.06, 0.04, 0.04), (0.20, 0.55, 0.25, 1.0)),
    ObjectSpec("box_3", 3, (0.04, 0.04, 0.07), (0.20, 0.35, 0.80, 1.0)),
)
"""The three cuboids of the scene (5x5x5, 6x4x4 and 4x4x7 cm)."""


@dataclass(frozen=True)
class CameraSpec:
    """A pinhole camera looking from ``position`` at ``target`` (world frame)."""

    position: tuple[float, float, float] = (0.0, 0.62, 0.64)
    target: tuple[float, float, float] = (0.0, 0.15, 0.0)
    width: int = 640
    height: int = 480
    focal_px: float = 615.0

    @property
    def fovy_deg(self) -> float:
        """MuJoCo's vertical field of view for :attr:`focal_px`."""
        return float(np.rad2deg(2.0 * np.arctan(0.5 * self.height / self.focal_px)))

    def rotation_cv(self) -> np.ndarray:
        """World rotation of the OpenCV camera frame (x right, y down, z forward), shape (3, 3)."""
        z = np.asarray(self.target, float) - np.asarray(self.position, float)
        z /= np.linalg.norm(z)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        return np.column_stack([x, y, z])

    def intrinsics(self) -> np.ndarray:
        """The 3x3 intrinsic matrix (principal point at the image centre, pixel centres integer)."""
        f = (0.5 * self.height) / np.tan(np.deg2rad(self.fovy_deg) / 2.0)
        return np.array(
            [[f, 0.0, (self.width - 1) / 2.0], [0.0, f, (self.height - 1) / 2.0], [0.0, 0.0, 1.0]]
        )

    def world_T_camera(self) -> np.ndarray:
        """Homogeneous pose of the OpenCV camera frame in the world, shape (4, 4)."""
        T = np.eye(4)
        T[:3, :3] = self.rotation_cv()
        T[:3, 3] = self.position
        return T


@dataclass
class Scene:
    """A compiled-ready scene: MJCF text, its texture assets and what it contains."""

    xml: str
    assets: dict[str, bytes]
    objects: tuple[ObjectSpec, ...]
    camera: CameraSpec
    hand_scale: float
    extra: dict[str, float] = field(default_factory=dict)
    sides: tuple[str, ...] = ("right",)
    """The hands in the scene: the right one, and the left one (names prefixed ``left_``)."""

    def compile(self):  # type: ignore[no-untyped-def]
        """Compile into a ``mujoco.MjModel``."""
        import mujoco

        return mujoco.MjModel.from_xml_string(self.xml, self.assets)


def forearm_quat(wrist: np.ndarray, shoulder: np.ndarray | None = None) -> np.ndarray:
    """Orientation (w, x, y, z) of the forearm body: its +x axis from the wrist to the elbow.

    The elbow is placed roughly below and in front of the shoulder (default
    :data:`DEMONSTRATOR_SHOULDER`, the right one).
    """
    base = DEMONSTRATOR_SHOULDER if shoulder is None else np.asarray(shoulder, float)
    elbow = base + np.array([0.0, 0.15, -0.12])
    x = elbow - np.asarray(wrist, float)
    x /= np.linalg.norm(x)
    z = np.array([0.0, 0.0, 1.0]) - x * x[2]
    z /= np.linalg.norm(z)
    y = np.cross(z, x)
    R = np.column_stack([x, y, z])
    w = np.sqrt(max(1e-12, 1.0 + np.trace(R))) / 2.0
    return np.array(
        [
            w,
            (R[2, 1] - R[1, 2]) / (4 * w),
            (R[0, 2] - R[2, 0]) / (4 * w),
            (R[1, 0] - R[0, 1]) / (4 * w),
        ]
    )


def tag_png(tag_id: int, *, margin_fraction: float = 0.0, cell_px: int = 20) -> bytes:
    """PNG bytes of an ArUco DICT_4X4_50 marker with a white margin (fraction of the full side)."""
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    side = 6 * cell_px
    img = cv2.aruco.generateImageMarker(dictionary, int(tag_id), side)
    pad = round(side * margin_fraction / (1.0 - 2.0 * margin_fraction)) if margin_fraction else 0
    img = cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(img, cv2.COLOR_GRAY2RGB))
    if not ok:  # pragma: no cover - cv2 always encodes PNG
        raise RuntimeError("could not encode tag texture")
    return bytes(buf.tobytes())


def build_scene(
    objects: tuple[ObjectSpec, ...] = DEFAULT_OBJECTS,
    *,
    hand_scale: float = 1.0,
    camera: CameraSpec | None = None,
    sides: tuple[str, ...] = ("right",),
) -> Scene:
    """Write the MJCF of the workspace.

    Boxes are bodies with a free joint named ``<name>`` (posed kinematically by the
    demonstrator); their tag is a thin textured box on the top face. The reference marker is a
    thin textured box at the origin with a white margin (total side 0.12 m). ``sides``
    ``("right", "left")`` adds the left hand and forearm (names prefixed ``left_``).
    """
    camera = camera or CameraSpec()
    assets = {"tag_0.png": tag_png(REFERENCE_TAG_ID, margin_fraction=1.0 / 12.0)}
    asset_xml = [
        '<texture name="tex_0" type="2d" file="tag_0.png"/>',
        '<material name="mat_0" texture="tex_0"/>',
        '<texture name="grid" type="2d" builtin="checker" rgb1="0.72 0.60 0.45"'
        ' rgb2="0.70 0.58 0.43" width="512" height="512"/>',
        '<material name="table" texture="grid" texrepeat="8 8" texuniform="true"/>',
    ]
    bodies = []
    for spec in objects:
        assets[f"tag_{spec.tag_id}.png"] = tag_png(spec.tag_id, margin_fraction=TAG_MARGIN)
        asset_xml.append(
            f'<texture name="tex_{spec.tag_id}" type="2d" file="tag_{spec.tag_id}.png"/>'
        )
        asset_xml.append(f'<material name="mat_{spec.tag_id}" texture="tex_{spec.tag_id}"/>')
        sx, sy, sz = (0.5 * v for v in spec.size)
        side = min(sx, sy)
        rgba = " ".join(f"{c:g}" for c in spec.rgba)
        bodies.append(
            f'<body name="{spec.name}" pos="0 0 {sz:.6g}">'
            f'<freejoint name="{spec.name}"/>'
            f'<geom name="{spec.name}" type="box" size="{sx:.6g} {sy:.6g} {sz:.6g}" rgba="{rgba}"'
            ' mass="0.1"/>'
            f'<geom name="{spec.name}_tag" type="box" size="{side:.6g} {side:.6g} 0.0002"'
            f' pos="0 0 {sz + 0.0002:.6g}" material="mat_{spec.tag_id}" contype="0"'
            ' conaffinity="0" mass="0"/>'
            "</body>"
        )
    R = camera.rotation_cv()
    xyaxes = np.concatenate([R[:, 0], -R[:, 1]])  # MuJoCo camera: x right, y up, looks along -z
    ref_half = REFERENCE_MARKER_SIZE / 2.0 * 12.0 / 10.0
    cam_xyz = " ".join(f"{v:.6g}" for v in camera.position)
    xml = f"""<mujoco model="lfd_demo_scene">
<compiler angle="degree"/>
<option timestep="0.005" gravity="0 0 -9.81"/>
<visual>
  <quality offsamples="0" shadowsize="0"/>
  <global offwidth="{camera.width}" offheight="{camera.height}"/>
  <headlight ambient="0.35 0.35 0.35" diffuse="0.45 0.45 0.45" specular="0 0 0"/>
  <map znear="0.01" zfar="20"/>
</visual>
<asset>
{chr(10).join(asset_xml)}
</asset>
<worldbody>
  <light name="top" pos="0.1 0.1 2.0" dir="0 0 -1" directional="true" castshadow="false"
    diffuse="0.5 0.5 0.5" specular="0 0 0"/>
  <geom name="table" type="box" pos="0 0.15 -0.02" size="0.75 0.55 0.02" material="table"/>
  <geom name="floor" type="plane" pos="0 0 -0.75" size="4 4 0.1" rgba="0.35 0.35 0.38 1"/>
  <geom name="wall" type="box" pos="0 -1.6 0.5" size="3 0.05 1.5" rgba="0.82 0.82 0.80 1"
    contype="0" conaffinity="0"/>
  <geom name="ref_marker" type="box" pos="0 0 0.0002" size="{ref_half:.6g} {ref_half:.6g} 0.0002"
    material="mat_0" contype="0" conaffinity="0"/>
  <camera name="cam" pos="{cam_xyz}" xyaxes="{" ".join(f"{v:.6g}" for v in xyaxes)}"
    fovy="{camera.fovy_deg:.6g}"/>
  {chr(10).join(bodies)}
  {hand_mjcf(hand_scale)}
  <body name="forearm" mocap="true">
    <geom name="forearm" type="capsule" fromto="0.03 0 0 {FOREARM_LENGTH} 0 0"
      size="{0.027 * hand_scale:.6g}" rgba="0.85 0.66 0.55 1" contype="0" conaffinity="0"/>
  </body>
  {_left_hand(hand_scale) if "left" in sides else ""}
</worldbody>
</mujoco>"""
    return Scene(
        xml=xml,
        assets=assets,
        objects=tuple(objects),
        camera=camera,
        hand_scale=hand_scale,
        sides=tuple(sides),
    )


def _left_hand(hand_scale: float) -> str:
    """The left hand and forearm bodies (``left_hand``, ``left_forearm``)."""
    return f"""{hand_mjcf(hand_scale, "left")}
  <body name="left_forearm" mocap="true">
    <geom name="left_forearm" type="capsule" fromto="0.03 0 0 {FOREARM_LENGTH} 0 0"
      size="{0.027 * hand_scale:.6g}" rgba="0.85 0.66 0.55 1" contype="0" conaffinity="0"/>
  </body>"""
