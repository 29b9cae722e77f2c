"""On-board camera (paper, "Camera"): mount pose, view/projection maths, depth, rendering.

A vehicle may carry any number of cameras anywhere on its body.  Each one is described
by a :class:`CameraParams`; the maths below is pure (numpy only) and the single adapter
:func:`capture` asks PyBullet's CPU renderer for the images.

Frames (see :mod:`pyflyt_engine.frames`): the ground frame is ENU, the body frame is
X forward, Y left, Z up.  The camera frame follows the body convention: the camera looks
along its own +X and its image "up" is its own +Z.  Its orientation relative to the body
is given as Euler angles (roll, pitch, yaw) in the project convention, so a positive
pitch tilts the camera *down* (right-hand rule about body +Y, which points left).

Pose of a camera on a body at ``p`` with body-to-ground rotation ``R_b``::

    eye     = p + R_b @ position                 (the mount point moves with the body)
    R_c     = R_att @ R_mount                    R_mount = Rz(yaw) Ry(pitch) Rx(roll)
    forward = R_c @ [1, 0, 0]      up = R_c @ [0, 0, 1]

with ``R_att = R_b`` for a body-fixed camera and ``R_att = Rz(body yaw)`` for a
horizon-locked (gimbal-stabilised) one: the gimbal removes body roll and pitch, and the
camera's own mount rotation still applies on top.

Images returned by :func:`capture` (``H = height``, ``W = width``, row 0 is the top of
the image, column 0 its left):

=================  ============  =======  ==============================================
channel            shape         dtype    content
=================  ============  =======  ==============================================
``rgba``           (H, W, 4)     uint8    colour, alpha 255
``depth``          (H, W, 1)     float32  distance [m] from the camera along its optical
                                          axis (+X) to the surface, not the ray length;
                                          about ``far`` where nothing is hit (the
                                          float32 buffer gives 99.99 for far = 100)
``segmentation``   (H, W, 1)     int32    PyBullet body unique id of the surface, -1 for
                                          background
=================  ============  =======  ==============================================

The paper writes the image shapes as w x h; here they are numpy's row-major (h, w).
Every pixel samples the ray through its centre (see :func:`pixel_centred_projection`),
so the optical axis falls on the image centre at any resolution, 1 x 1 included.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np

from pyflyt_engine import exact
from pyflyt_engine.bullet import pybullet as p
from pyflyt_engine.components import AirVelocity
from pyflyt_engine.components.kinds import BuildContext, register
from pyflyt_engine.errors import ConfigError
from pyflyt_engine.frames import ground_to_body_matrix, quaternion_to_rows
from pyflyt_engine.spec import CameraSpec

CHANNELS = ("rgba", "depth", "segmentation")
"""Every image channel a camera can return, in the order :func:`capture` fills them."""

_PARALLEL_TOL = 1e-12


def _vector3(name: str, value: Sequence[float]) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ConfigError(f"camera {name} must be 3 finite numbers, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _is_int(value: object) -> bool:
    return isinstance(value, Integral) and not isinstance(value, bool)


@dataclass(frozen=True)
class CameraParams:
    """One camera mounted on a vehicle.  Every field is checked on construction.

    ``position`` and ``orientation`` are stored as tuples of floats, ``channels`` as a
    tuple of names, so instances are hashable and compare by value.
    """

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """m, body frame: camera origin (the eye) relative to the body origin."""
    orientation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """rad: (roll, pitch, yaw) of the camera frame relative to the body frame (camera
    looks along its +X, up is its +Z).  Positive pitch looks down."""
    fov: float = 90.0
    """deg: vertical field of view, 0 < fov < 180.  The horizontal one follows from the
    aspect ratio width / height."""
    width: int = 128
    """pixels: image width (columns), >= 1."""
    height: int = 128
    """pixels: image height (rows), >= 1."""
    near: float = 0.1
    """m: near clip distance along the optical axis, 0 < near < far.  Depth resolution
    degrades with far / near."""
    far: float = 100.0
    """m: far clip distance along the optical axis; background pixels read ``far``."""
    horizon_lock: bool = False
    """True: gimbal-stabilised, the camera ignores body roll and pitch and follows only
    body yaw (the mount point still moves with the body)."""
    capture_hz: float = 30.0
    """Hz: rate at which the vehicle refreshes the image (enforced by the vehicle), > 0."""
    channels: tuple[str, ...] = CHANNELS
    """Which images :func:`capture` returns: a non-empty subset of :data:`CHANNELS`."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _vector3("position", self.position))
        object.__setattr__(self, "orientation", _vector3("orientation", self.orientation))

        for name in ("width", "height"):
            value = getattr(self, name)
            if not _is_int(value) or value < 1:
                raise ConfigError(f"camera {name} must be a whole number of pixels >= 1, got {value!r}")
            object.__setattr__(self, name, int(value))

        if not isinstance(self.fov, Real) or not 0.0 < self.fov < 180.0:
            raise ConfigError(
                f"camera fov is the vertical field of view in degrees and must satisfy 0 < fov < 180, got {self.fov!r}"
            )
        object.__setattr__(self, "fov", float(self.fov))

        for name in ("near", "far"):
            value = getattr(self, name)
            if not isinstance(value, Real) or not math.isfinite(value) or value <= 0:
                raise ConfigError(f"camera {name} clip distance must be a finite number > 0 m, got {value!r}")
            object.__setattr__(self, name, float(value))
        if not self.near < self.far:
            raise ConfigError(
                f"camera near ({self.near:g} m) must be less than far ({self.far:g} m); swap them or widen the range"
            )

        if not isinstance(self.horizon_lock, (bool, np.bool_)):
            raise ConfigError(f"camera horizon_lock must be True or False, got {self.horizon_lock!r}")
        object.__setattr__(self, "horizon_lock", bool(self.horizon_lock))

        if not isinstance(self.capture_hz, Real) or not math.isfinite(self.capture_hz) or self.capture_hz <= 0:
            raise ConfigError(f"camera capture_hz must be a finite rate > 0 Hz, got {self.capture_hz!r}")
        object.__setattr__(self, "capture_hz", float(self.capture_hz))

        channels = (self.channels,) if isinstance(self.channels, str) else tuple(self.channels)
        if not channels:
            raise ConfigError(f"camera channels must name at least one of {CHANNELS}, got none")
        for channel in channels:
            if channel not in CHANNELS:
                raise ConfigError(f"camera channel {channel!r} is unknown; choose from {CHANNELS}")
        if len(set(channels)) != len(channels):
            raise ConfigError(f"camera channels list a channel twice: {channels}; list each once")
        object.__setattr__(self, "channels", channels)

    @property
    def aspect(self) -> float:
        """Width / height of the image."""
        return self.width / self.height

    @property
    def mount_rotation(self) -> np.ndarray:
        """(3, 3) camera-to-body rotation Rz(yaw) Ry(pitch) Rx(roll) of ``orientation``."""
        return ground_to_body_matrix(*self.orientation).T


def camera_pose(
    params: CameraParams,
    body_position: Sequence[float] | np.ndarray,
    body_quaternion: Sequence[float] | np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the camera is and where it looks, in the ground frame.

    Args:
        params: the camera.
        body_position: (3,) body origin [m], ground frame.
        body_quaternion: (4,) body-to-ground attitude (x, y, z, w); normalised here.

    Returns:
        ``(eye, forward, up)``: (3,) eye position [m] and (3,) orthonormal unit vectors
        (camera +X and +Z), all in the ground frame.  With ``horizon_lock`` only the
        body's yaw (heading of its +X axis) is used for the direction; that heading is
        undefined when the body points straight up or down, where yaw 0 is used.
    """
    q = [float(v) for v in body_quaternion]
    size = exact.norm(q)
    body_rotation = quaternion_to_rows([v / size for v in q])
    mount = exact.rotate(body_rotation, params.position)
    eye = np.array([float(b) + m for b, m in zip(body_position, mount)])

    if params.horizon_lock:
        yaw = math.atan2(body_rotation[1][0], body_rotation[0][0])
        attitude = ground_to_body_matrix(0.0, 0.0, yaw).T.tolist()
    else:
        attitude = body_rotation
    mount_rotation = params.mount_rotation.tolist()
    # columns 0 (camera +X) and 2 (camera +Z) of attitude @ mount_rotation
    forward = exact.rotate(attitude, [row[0] for row in mount_rotation])
    up = exact.rotate(attitude, [row[2] for row in mount_rotation])
    return eye, np.array(forward), np.array(up)


def view_matrix(
    eye: Sequence[float] | np.ndarray,
    forward: Sequence[float] | np.ndarray,
    up: Sequence[float] | np.ndarray,
) -> tuple[float, ...]:
    """OpenGL look-at view matrix (ground -> eye coordinates), 16 floats column-major.

    The same matrix as ``pybullet.computeViewMatrix(eye, eye + forward, up)`` (gluLookAt):
    ``f = forward / |forward|``, ``s = unit(f x up)``, ``u = s x f`` and rows
    ``[s, -s.eye]``, ``[u, -u.eye]``, ``[-f, f.eye]``, ``[0, 0, 0, 1]``.  ``up`` need not
    be orthogonal to ``forward``, only not parallel to it.
    """
    e = [float(v) for v in eye]
    f = [float(v) for v in forward]
    length = exact.norm(f)
    f = [v / length for v in f]
    s = exact.cross(f, [float(v) for v in up])
    norm = exact.norm(s)
    if norm < _PARALLEL_TOL:
        raise ValueError(f"view_matrix: up {up!r} is parallel to forward {forward!r}; give an up not along the view")
    s = (s[0] / norm, s[1] / norm, s[2] / norm)
    u = exact.cross(s, f)
    se, ue, fe = (c[0] * e[0] + c[1] * e[1] + c[2] * e[2] for c in (s, u, f))
    # column-major, as OpenGL and PyBullet take it: one line per column of the matrix
    return (
        s[0], u[0], -f[0], 0.0,
        s[1], u[1], -f[1], 0.0,
        s[2], u[2], -f[2], 0.0,
        -se, -ue, fe, 1.0,
    )  # fmt: skip


def projection_matrix(params: CameraParams) -> tuple[float, ...]:
    """OpenGL perspective projection, 16 floats column-major.

    The same matrix as ``pybullet.computeProjectionMatrixFOV(fov, width / height, near,
    far)``: ``y_scale = 1 / tan(fov / 2)``, ``x_scale = y_scale / aspect``, and the depth
    rows map eye-space z = -near..-far to normalised depth -1..1.
    """
    y_scale = 1.0 / math.tan(math.radians(params.fov) / 2.0)
    x_scale = y_scale / params.aspect
    n, f = params.near, params.far
    return (
        x_scale, 0.0, 0.0, 0.0,
        0.0, y_scale, 0.0, 0.0,
        0.0, 0.0, (f + n) / (n - f), -1.0,
        0.0, 0.0, 2.0 * f * n / (n - f), 0.0,
    )  # fmt: skip


def pixel_centred_projection(params: CameraParams) -> tuple[float, ...]:
    """:func:`projection_matrix` shifted half a pixel so that each pixel samples its centre.

    PyBullet's TinyRenderer rasterises at integer pixel coordinates, i.e. it samples
    every pixel at its lower-left corner (measured: a 1 x 1 image sees the bottom-left
    corner of the frustum, not the optical axis).  Adding ``1 / width`` and
    ``1 / height`` to the z column (entries 8 and 9, column-major) moves normalised
    device coordinates by ``-1 / width`` and ``-1 / height`` -- half a pixel -- so pixel
    (row r, column c) sees the ray through its centre, as an ideal pinhole camera (and
    OpenGL) would: the optical axis falls on the image centre for any resolution.
    Depth is unchanged: the z and w rows of the matrix are untouched.
    """
    matrix = list(projection_matrix(params))
    matrix[8] += 1.0 / params.width
    matrix[9] += 1.0 / params.height
    return tuple(matrix)


def linearise_depth(zbuffer: float | np.ndarray, near: float, far: float) -> np.ndarray:
    """Depth along the optical axis [m] from PyBullet's depth buffer values in [0, 1].

    The buffer stores the window depth ``d = (z_ndc + 1) / 2`` of the perspective
    projection, so the eye-space distance is ``near * far / (far - (far - near) * d)``:
    ``d = 0`` gives ``near`` and ``d = 1`` gives ``far``.

    Returns:
        float64 array of the shape of ``zbuffer`` (0-d for a scalar).
    """
    d = np.asarray(zbuffer, dtype=np.float64)
    return near * far / (far - (far - near) * d)


def capture(
    client: int,
    params: CameraParams,
    body_position: Sequence[float] | np.ndarray,
    body_quaternion: Sequence[float] | np.ndarray,
) -> dict[str, np.ndarray]:
    """Render the camera's view with PyBullet's CPU renderer (works headless, DIRECT).

    Args:
        client: PyBullet physics client id.
        params: the camera.
        body_position: (3,) body origin [m], ground frame.
        body_quaternion: (4,) body attitude (x, y, z, w).

    Returns:
        ``{channel: image}`` for each of ``params.channels`` only; shapes, dtypes and
        units in the module docstring.  Arrays are fresh, owned by the caller.
    """
    eye, forward, up = camera_pose(params, body_position, body_quaternion)
    want_segmentation = "segmentation" in params.channels
    _, _, rgba, zbuffer, segmentation = p.getCameraImage(
        params.width,
        params.height,
        viewMatrix=view_matrix(eye, forward, up),
        projectionMatrix=pixel_centred_projection(params),
        renderer=p.ER_TINY_RENDERER,
        # TinyRenderer then leaves the segmentation buffer stale (never read it); the flag
        # saved no measurable time at 128 x 128, rasterisation dominates every channel
        flags=0 if want_segmentation else p.ER_NO_SEGMENTATION_MASK,
        physicsClientId=client,
    )
    shape = (params.height, params.width)
    images: dict[str, np.ndarray] = {}
    if "rgba" in params.channels:
        images["rgba"] = np.asarray(rgba, dtype=np.uint8).reshape(*shape, 4)
    if "depth" in params.channels:
        depth = linearise_depth(np.asarray(zbuffer).reshape(*shape, 1), params.near, params.far)
        images["depth"] = depth.astype(np.float32)
    if want_segmentation:
        images["segmentation"] = np.asarray(segmentation, dtype=np.int32).reshape(*shape, 1)
    return images


class Cameras:
    """The cameras of one vehicle: their parameters and the last images of each.

    Cameras are sensors: they are not stepped with the physics and apply no load; an
    image is rendered when asked for, at most once per ``1 / capture_hz`` of simulated
    time (the last one is returned in between).  As a group of the vehicle they are
    reset with it and otherwise left out of the control and physics steps.
    """

    needs_air = False
    commanded = False

    def __init__(self, params: Sequence[CameraParams]) -> None:
        self.params = tuple(params)
        self._last: dict[int, tuple[float, dict[str, np.ndarray]]] = {}

    def capture(
        self,
        client: int,
        index: int,
        body_position: Sequence[float],
        body_quaternion: Sequence[float],
        time: float | None = None,
    ) -> dict[str, np.ndarray]:
        """Images of camera ``index`` (:func:`capture`); with ``time`` (simulated seconds) a
        cached image younger than ``1 / capture_hz`` is returned instead of a new one."""
        params = self.params[index]
        cached = self._last.get(index)
        if time is not None and cached is not None and time - cached[0] < 1.0 / params.capture_hz - 1e-9:
            return cached[1]
        images = capture(client, params, body_position, body_quaternion)
        self._last[index] = (time if time is not None else float("nan"), images)
        return images

    def route(self, channels: Sequence[float], outputs: Sequence[float] | None = None) -> None:
        """Nothing commands a camera."""

    def step(self, air: AirVelocity, thrust_ratio: Sequence[float] | None = None) -> None:
        """Not stepped (``step_order`` None): rendered when asked for."""

    def reset(self) -> None:
        """Forget the last images."""
        self._last.clear()

    def reseed(self) -> None:
        """No noise: nothing to do."""

    def aux(self) -> list[float]:
        """No read-outs (images are observations of their own)."""
        return []


def build_cameras(ctx: BuildContext) -> Cameras:
    """The cameras' group, also without cameras (``Vehicle.capture`` names the count)."""
    return Cameras(ctx.parts.cameras)


register("cameras", section="cameras", spec=CameraSpec, build=build_cameras, order=60, step_order=None)
