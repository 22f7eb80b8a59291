r"""Cameras of a robot model (irteus manual: ``:cameras``, ``camera-model``).

A :class:`Camera` is an MJCF ``<camera>`` taken by name. Everything geometric
comes from MuJoCo:

* **Extrinsics**: ``cam_xpos`` / ``cam_xmat``, computed from the bodies' poses
  by ``mj_camlight`` where a camera is used. A MuJoCo
  camera frame ``C`` has x to the right of the image, y up, and looks along −z.
* **Intrinsics** of a ``W x H`` image are those of the frustum MuJoCo renders
  the camera with. Pixel coordinates are continuous, u to the right, v down,
  pixel ``(i, j)`` covering ``[i, i+1) x [j, j+1)`` (the image centre is
  ``(W/2, H/2)``). A camera with only ``fovy`` has square pixels and a centred
  principal point (its horizontal extent follows the image's aspect ratio):

  .. math::

      f_x = f_y = \frac{H/2}{\tan(\mathrm{fovy}/2)}, \qquad (c_x, c_y) = (W/2, H/2)

  A camera with a physical sensor (``sensorsize`` ``(s_x, s_y)`` [m], focal
  lengths ``(φ_x, φ_y)`` and principal offset ``(π_x, π_y)`` [m]: MuJoCo's
  ``cam_sensorsize`` and ``cam_intrinsic``) is drawn with the frustum
  ``x/d ∈ [−(s_x/2 − π_x)/φ_x, (s_x/2 + π_x)/φ_x]``,
  ``y/d ∈ [−(s_y/2 + π_y)/φ_y, (s_y/2 − π_y)/φ_y]`` stretched over the image:

  .. math::

      f_x = W \frac{φ_x}{s_x},\; c_x = W \left(\frac12 - \frac{π_x}{s_x}\right),\qquad
      f_y = H \frac{φ_y}{s_y},\; c_y = H \left(\frac12 - \frac{π_y}{s_y}\right)

* **Projection** of a world point ``p_W``: ``p_C = R_WCᵀ (p_W − p_WC)``,
  depth ``d = −z_C`` (> 0 in front of the camera),

  .. math::

      u = c_x + f_x \frac{x_C}{d}, \qquad v = c_y - f_y \frac{y_C}{d}

* **Visibility** of a point, site, geom or body: in the image, in front of
  the near plane, and not occluded — the first surface MuJoCo's ray caster
  (``mj_ray``, geom groups as rendered, the camera's own body excluded) meets
  on the way from the camera to the point is farther than the point or belongs
  to the target's own body.
* **Images**: MuJoCo's offscreen renderer (``mjv_updateScene`` +
  ``mjr_render``) through :class:`CameraRenderer`, on the OpenGL backend named
  by ``MUJOCO_GL`` or, when it is unset, the first of EGL, OSMesa, GLFW that
  works. Where none does, :class:`RenderingUnavailable` says why; projection
  and visibility do not need OpenGL.

:func:`log_camera` writes a camera to a rerun recording as a pinhole camera
(``rr.Transform3D`` + ``rr.Pinhole``, and the image when there is one).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj.exceptions import InvalidInput, RenderingUnavailable, UnknownName
from pik_mj.frames import Frame

__all__ = [
    "DEFAULT_SIZE",
    "RENDERED_GEOM_GROUPS",
    "Camera",
    "CameraRenderer",
    "Intrinsics",
    "RenderingUnavailable",
    "Visibility",
    "camera_names",
    "log_camera",
]

DEFAULT_SIZE = (320, 240)
"""Image ``(width, height)`` [px] of a camera whose MJCF gives no ``resolution``
(irteus' ``camera-model`` default)."""

RENDERED_GEOM_GROUPS = (1, 1, 1, 0, 0, 0)
"""Geom groups MuJoCo draws by default (``mjvOption.geomgroup``): the groups the
visibility rays can hit."""

_BACKENDS = ("egl", "osmesa", "glfw")


def camera_names(model: mujoco.MjModel) -> list[str]:
    """Names of the model's cameras."""
    names = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam))
    return [n for n in names if n]


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of an image, in pixels (u right, v down).

    Attributes:
        width: Image width [px].
        height: Image height [px].
        fx: Focal length along u [px].
        fy: Focal length along v [px].
        cx: Principal point u [px] (``width / 2`` for a centred camera).
        cy: Principal point v [px].
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    @property
    def K(self) -> np.ndarray:
        """The 3x3 matrix ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` mapping camera
        coordinates (x right, y down, z forward) to homogeneous pixels."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Visibility:
    """Whether a camera sees a point.

    Attributes:
        point: The tested point ``p_W`` [m].
        pixel: Its projection ``(u, v)`` [px] (meaningless when ``depth <= 0``).
        depth: Distance in front of the camera along its view direction [m].
        in_view: In front of the near plane and inside the image.
        occluder: Name (or ``"geom <id>"``) of the first geom the ray from the
            camera meets before the point, None when nothing is in between.
    """

    point: np.ndarray
    pixel: np.ndarray
    depth: float
    in_view: bool
    occluder: str | None

    @property
    def visible(self) -> bool:
        """In view and not occluded."""
        return self.in_view and self.occluder is None


class Camera:
    """An MJCF camera of ``model``, by name, with the intrinsics of an image size.

    Args:
        model: The model holding the camera (a robot alone or a scene with it).
        name: The camera's MJCF name.
        width: Image width [px]; default: the camera's ``resolution`` when the
            MJCF sets one, else :data:`DEFAULT_SIZE`.
        height: Image height [px]; default as ``width``.

    Attributes:
        model, name, id: The camera.
        body_id: The body carrying it.
        intrinsics: :class:`Intrinsics` of the ``width x height`` image.
        near: Near clipping distance [m] (MuJoCo's ``znear · extent``).

    Raises:
        UnknownName: No camera of that name (the message lists the cameras).
        InvalidInput: A bad image size, or an orthographic camera.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        name: str,
        *,
        width: int | None = None,
        height: int | None = None,
    ):
        cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if cam < 0:
            raise UnknownName("camera", name, camera_names(model))
        if int(model.cam_projection[cam]) != int(mujoco.mjtProjection.mjPROJ_PERSPECTIVE):
            raise InvalidInput(f"camera {name!r} is orthographic; only perspective cameras project")
        res = model.cam_resolution[cam]
        own = (int(res[0]), int(res[1])) if min(res) > 1 else DEFAULT_SIZE
        w = own[0] if width is None else width
        h = own[1] if height is None else height
        if not all(isinstance(n, int | np.integer) and n > 0 for n in (w, h)):
            raise InvalidInput(f"image width and height must be positive integers, got {w}, {h}")
        self.model = model
        self.name = name
        self.id = int(cam)
        self.body_id = int(model.cam_bodyid[cam])
        self.intrinsics = self._intrinsics(int(w), int(h))
        self.near = float(model.vis.map.znear * model.stat.extent)

    def _intrinsics(self, width: int, height: int) -> Intrinsics:
        """Intrinsics of the frustum MuJoCo renders this camera with (module docstring)."""
        m, cam = self.model, self.id
        sensor = m.cam_sensorsize[cam].astype(float)
        if sensor[0] > 0 and sensor[1] > 0:
            # focal lengths and principal offset [m] on a sensor of size sensor [m]
            f_x, f_y, p_x, p_y = m.cam_intrinsic[cam].astype(float)
            return Intrinsics(
                width=width,
                height=height,
                fx=width * f_x / sensor[0],
                fy=height * f_y / sensor[1],
                cx=width * (0.5 - p_x / sensor[0]),
                cy=height * (0.5 - p_y / sensor[1]),
            )
        f = 0.5 * height / math.tan(math.radians(float(m.cam_fovy[cam])) / 2)
        return Intrinsics(width=width, height=height, fx=f, fy=f, cx=0.5 * width, cy=0.5 * height)

    # ------------------------------------------------------------------ pose
    def pose(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """``(p_WC (3,) [m], R_WC (3, 3))`` of the camera frame (x right, y up,
        looking along −z), computed here from the bodies' poses
        (``mj_camlight``): ``mj_kinematics`` alone leaves ``cam_xpos`` and
        ``cam_xmat`` stale. The bodies' poses must be current; a camera that
        tracks a centre of mass needs them after ``mj_comPos`` (which
        ``mj_forward`` runs)."""
        mujoco.mj_camlight(self.model, data)
        return data.cam_xpos[self.id].copy(), data.cam_xmat[self.id].reshape(3, 3).copy()

    def project(self, data: mujoco.MjData, points: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Pixels of world points (module docstring).

        Args:
            data: State with current kinematics.
            points: ``p_W`` (3,) or (n, 3) [m].

        Returns:
            ``(pixels (n, 2) [px], depth (n,) [m])``, or ``((2,), float)`` for one
            point. A point behind the camera has ``depth <= 0`` and a pixel that
            means nothing.
        """
        p = _points(points)
        p_WC, R_WC = self.pose(data)
        p_C = (p - p_WC) @ R_WC  # rows: R_WCᵀ (p_W − p_WC)
        depth = -p_C[:, 2]
        k = self.intrinsics
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.column_stack([k.cx + k.fx * p_C[:, 0] / depth, k.cy - k.fy * p_C[:, 1] / depth])
        if np.ndim(points) == 1:
            return uv[0], float(depth[0])
        return uv, depth

    def in_view(self, data: mujoco.MjData, points: ArrayLike) -> np.ndarray:
        """True where a world point is in front of the near plane and inside the
        image: ``depth >= near``, ``0 <= u <= W``, ``0 <= v <= H``."""
        uv, depth = self.project(data, _points(points))
        return self._inside(uv, depth)

    def _inside(self, uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
        k = self.intrinsics
        u, v = np.atleast_2d(uv).T
        return (
            (np.atleast_1d(depth) >= self.near)
            & (u >= 0)
            & (u <= k.width)
            & (v >= 0)
            & (v <= k.height)
        )

    # ------------------------------------------------------------ visibility
    def visibility(
        self,
        data: mujoco.MjData,
        target: str | ArrayLike,
        *,
        geomgroup: Sequence[int] = RENDERED_GEOM_GROUPS,
    ) -> Visibility:
        """Whether the camera sees ``target``.

        Args:
            data: State with current kinematics.
            target: A world point (3,) [m], or the name of a site, geom or body.
                A site or geom is tested at its origin, and its own body cannot
                occlude it. A body is seen when one of its geoms in ``geomgroup``
                is (tested at the geom centres, best first: visible, else in
                view); a body without such geoms is tested at its origin.
            geomgroup: Geom groups the rays can hit (6 flags, as
                ``mjvOption.geomgroup``).

        Returns:
            A :class:`Visibility`.

        Raises:
            UnknownName: ``target`` names no site, geom or body.
        """
        group = np.asarray(geomgroup, dtype=np.uint8)
        if group.shape != (6,):
            raise InvalidInput(f"geomgroup must be 6 flags, got {geomgroup!r}")
        if not isinstance(target, str):
            return self._point_visibility(data, _points(target)[0], -1, group)
        frame = Frame.find(self.model, target)
        if frame.frame_type != "body":
            return self._point_visibility(data, frame.position(data), frame.body_id, group)
        m = self.model
        geoms = [
            g
            for g in range(m.ngeom)
            if m.geom_bodyid[g] == frame.id and group[min(int(m.geom_group[g]), 5)]
        ]
        points = data.geom_xpos[geoms] if geoms else data.xpos[[frame.id]]
        results = [self._point_visibility(data, p, frame.id, group) for p in points]
        return max(results, key=lambda r: (r.visible, r.in_view))

    def _point_visibility(
        self, data: mujoco.MjData, p_W: np.ndarray, own_body: int, group: np.ndarray
    ) -> Visibility:
        uv, depth = self.project(data, p_W)
        in_view = bool(self._inside(uv, depth)[0])
        p_WC = data.cam_xpos[self.id]  # computed by project
        ray = p_W - p_WC
        dist = float(np.linalg.norm(ray))
        occluder = None
        if dist > 0:
            geom = np.full(1, -1, dtype=np.int32)
            # a camera fixed in the world excludes no body (body 0 holds the floor)
            exclude = self.body_id if self.body_id > 0 else -1
            hit = mujoco.mj_ray(self.model, data, p_WC, ray / dist, group, 1, exclude, geom, None)
            g = int(geom[0])
            if 0 <= hit < dist - 1e-9 and g >= 0 and int(self.model.geom_bodyid[g]) != own_body:
                occluder = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom {g}"
        return Visibility(
            point=np.array(p_W, dtype=float),
            pixel=np.asarray(uv, dtype=float),
            depth=depth,
            in_view=in_view,
            occluder=occluder,
        )

    def __repr__(self) -> str:
        k = self.intrinsics
        return f"Camera({self.name!r}, {k.width}x{k.height} px, fx={k.fx:.1f}, fy={k.fy:.1f})"


def _points(points: ArrayLike) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise InvalidInput(f"points must be finite, of shape (3,) or (n, 3), got shape {p.shape}")
    return p


# ----------------------------------------------------------------------------
# rendering
# ----------------------------------------------------------------------------

_working_backend: str | None = None


def _gl_context_class(backend: str) -> Any:
    if backend == "egl":
        from mujoco.egl import GLContext
    elif backend == "osmesa":
        from mujoco.osmesa import GLContext
    elif backend == "glfw":
        from mujoco.glfw import GLContext
    else:
        raise InvalidInput(f"unknown OpenGL backend {backend!r}; valid: {list(_BACKENDS)}")
    return GLContext


def _open_gl_context(width: int, height: int) -> tuple[Any, str]:
    """A current offscreen GL context and its backend name.

    ``MUJOCO_GL`` names the backend when set; otherwise EGL, OSMesa and GLFW are
    tried in turn and the first that works is kept for the process (PyOpenGL
    binds one platform per process).
    """
    global _working_backend
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen:
        candidates: tuple[str, ...] = (chosen,)
    elif _working_backend is not None:
        candidates = (_working_backend,)
    else:
        candidates = _BACKENDS
    errors = []
    for backend in candidates:
        try:
            ctx = _gl_context_class(backend)(width, height)
            ctx.make_current()
        except Exception as err:  # every backend fails its own way (ImportError, GLError, ...)
            errors.append(f"{backend}: {type(err).__name__}: {err}")
            continue
        _working_backend = backend
        return ctx, backend
    how = f"MUJOCO_GL={chosen!r}" if chosen else "MUJOCO_GL unset, tried " + ", ".join(candidates)
    raise RenderingUnavailable(
        f"MuJoCo offscreen rendering is unavailable ({how}): {'; '.join(errors)}. "
        "Headless Linux renders with Mesa EGL (MUJOCO_GL=egl, package libegl1) or OSMesa "
        "(MUJOCO_GL=osmesa, libosmesa6). Camera projection and visibility work without it."
    )


class CameraRenderer:
    """MuJoCo's offscreen renderer for the cameras of one model.

    Use as a context manager (or call :meth:`close`): the GL context is freed
    deterministically instead of at interpreter exit.

    Args:
        model: The model (its ``<visual><global offwidth offheight>`` bound the
            image size; MuJoCo's default is 640 x 480).
        width: Image width [px].
        height: Image height [px].

    Attributes:
        backend: The OpenGL backend in use (``"egl"``, ``"osmesa"``, ``"glfw"``).

    Raises:
        RenderingUnavailable: No backend works (the message lists each one's error).
        InvalidInput: The image is larger than the model's offscreen buffer.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int):
        buf_w, buf_h = model.vis.global_.offwidth, model.vis.global_.offheight
        if not (0 < width <= buf_w and 0 < height <= buf_h):
            raise InvalidInput(
                f"image {width}x{height} px does not fit the model's offscreen buffer "
                f"{buf_w}x{buf_h}; raise <visual><global offwidth=... offheight=.../>"
            )
        self.model = model
        self.width, self.height = int(width), int(height)
        self._gl, self.backend = _open_gl_context(self.width, self.height)
        self._mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        self._scene = mujoco.MjvScene(model, maxgeom=10_000)
        self.option = mujoco.MjvOption()
        self._rect = mujoco.MjrRect(0, 0, self.width, self.height)

    def render(self, data: mujoco.MjData, camera: Camera | str) -> np.ndarray:
        """RGB image ``(height, width, 3)`` uint8 of ``camera``, row 0 at the top."""
        if self._gl is None:
            raise InvalidInput("the renderer is closed")
        cam_id = camera.id if isinstance(camera, Camera) else Camera(self.model, camera).id
        view = mujoco.MjvCamera()
        view.type = mujoco.mjtCamera.mjCAMERA_FIXED
        view.fixedcamid = cam_id
        self._gl.make_current()
        mujoco.mjv_updateScene(
            self.model, data, self.option, None, view, mujoco.mjtCatBit.mjCAT_ALL, self._scene
        )
        mujoco.mjr_render(self._rect, self._scene, self._mjr)
        rgb = np.empty((self.height, self.width, 3), dtype=np.uint8)
        mujoco.mjr_readPixels(rgb, None, self._rect, self._mjr)
        return np.flipud(rgb)  # OpenGL's row 0 is the bottom

    def close(self) -> None:
        """Free the MuJoCo and GL contexts (idempotent)."""
        if self._gl is None:
            return
        self._mjr.free()
        self._gl.free()
        self._gl = None

    def __enter__(self) -> CameraRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# ----------------------------------------------------------------------------
# recording
# ----------------------------------------------------------------------------


def log_camera(
    stream: Any,
    camera: Camera,
    data: mujoco.MjData,
    *,
    path: str | None = None,
    image: np.ndarray | None = None,
    image_plane_distance: float = 0.2,
) -> str:
    """Log ``camera`` to a rerun recording as a pinhole camera at its current pose.

    ``path`` gets ``rr.Transform3D(p_WC, R_WC)`` (the MuJoCo camera frame),
    ``path/image`` gets ``rr.Pinhole`` (``K`` of :class:`Intrinsics`,
    ``camera_xyz = RUB``: x right, y up, looking along −z) and, when given, the
    image. Time is whatever the caller set on ``stream``.

    Args:
        stream: An explicit ``rerun.RecordingStream``.
        camera: The camera.
        data: State with current kinematics.
        path: Entity path; default ``world/cameras/<name>``.
        image: RGB ``(height, width, 3)`` uint8, e.g. from :class:`CameraRenderer`.
        image_plane_distance: Where the viewer draws the image plane [m].

    Returns:
        The entity path of the pinhole (``path/image``).
    """
    import rerun as rr

    if not (math.isfinite(image_plane_distance) and image_plane_distance > 0):
        raise InvalidInput(f"image_plane_distance must be > 0 [m], got {image_plane_distance}")
    k = camera.intrinsics
    if image is not None and (
        np.shape(image) != (k.height, k.width, 3) or np.asarray(image).dtype != np.uint8
    ):
        raise InvalidInput(
            f"image must be uint8 of shape ({k.height}, {k.width}, 3), got "
            f"{np.asarray(image).dtype} {np.shape(image)}"
        )
    base = path if path is not None else f"world/cameras/{rr.escape_entity_path_part(camera.name)}"
    p_WC, R_WC = camera.pose(data)
    stream.log(base, rr.Transform3D(translation=p_WC, mat3x3=R_WC))
    pinhole = f"{base}/image"
    stream.log(
        pinhole,
        rr.Pinhole(
            image_from_camera=k.K,
            resolution=[k.width, k.height],
            camera_xyz=rr.ViewCoordinates.RUB,
            image_plane_distance=image_plane_distance,
        ),
    )
    if image is not None:
        stream.log(pinhole, rr.Image(image))
    return pinhole
