"""Where a view's camera stands: framing a bounding box from above the part's table plane, on the
side away from the robot (so the arm and torch stand behind the part, not between it and the
camera), and moving a target's cameras there. Pure but for `set_camera` (see `session.fit`)."""

from __future__ import annotations

import contextlib
from collections.abc import Collection, Sequence

import numpy as np

from .scene import Part
from .simulation import SimulationPart
from .target import Target

# Camera: looking down at ~35° (elevation), framing the bounding sphere with viser's default 75°
# vertical field of view plus a margin, so the framed box fills ~80 % of the view's height.
CAMERA_ELEVATION_DEG = 35.0
CAMERA_FOV_DEG = 75.0
CAMERA_MARGIN = 1.1

Camera = tuple[tuple[float, ...], tuple[float, ...], float, float]  # (eye, look_at, near, far)


def framing(center: np.ndarray, radius: float, direction: np.ndarray) -> Camera:
    """The camera framing a sphere (`center`, `radius` mm) from `direction` (unit, part → eye)."""
    dist = CAMERA_MARGIN * radius / np.sin(np.radians(CAMERA_FOV_DEG / 2))
    eye = center + dist * direction
    return (tuple(float(x) for x in eye), tuple(float(x) for x in center), dist * 1e-3, dist * 20)


def view_direction(parts: Collection[Part], time_s: float, center: np.ndarray) -> np.ndarray:
    """Unit vector from the part to the camera: CAMERA_ELEVATION_DEG above the part's own
    table plane (the positioner may have tilted it: the camera stays on the part's side of
    the table, never looking at the part through it), at `azimuth` about the world z."""
    az = azimuth(parts, center)
    el = np.radians(CAMERA_ELEVATION_DEG)
    up = np.array([0.0, 0.0, 1.0])
    for p in parts:
        if isinstance(p, SimulationPart):
            pose = p.work_pose(time_s)
            if pose is not None:
                up = pose[0][:, 2] / np.linalg.norm(pose[0][:, 2])
                break
    h = np.array([np.cos(az), np.sin(az), 0.0])
    h = h - (h @ up) * up
    if np.linalg.norm(h) < 1e-6:
        h = np.cross(up, [1.0, 0.0, 0.0])
    h /= np.linalg.norm(h)
    return np.cos(el) * h + np.sin(el) * up


def azimuth(parts: Collection[Part], center: np.ndarray) -> float:
    """Camera azimuth (rad): 40° off the direction robot base → part, so the part is seen
    in front of the arm; without a cell the classic front-left-above view."""
    for p in parts:
        if isinstance(p, SimulationPart):
            base = p.robot_base()
            if base is not None:
                d = center[:2] - base[:2]
                if np.linalg.norm(d) > 1e-6:
                    return float(np.arctan2(d[1], d[0]) + np.radians(40.0))
    return float(np.arctan2(-0.58, 0.42))


def set_camera(target: Target, eye: Sequence[float], center: Sequence[float], near: float, far: float) -> None:
    """Move the target's initial camera (what a client connecting later starts from) and every
    connected camera to `eye`, looking at `center`."""
    cam = target.initial_camera
    if cam is not None:
        cam.near, cam.far = near, far
        cam.position, cam.look_at = tuple(eye), tuple(center)
    for camera in target.cameras():
        with contextlib.suppress(Exception):
            camera.near, camera.far = near, far
            camera.position, camera.look_at = tuple(eye), tuple(center)
