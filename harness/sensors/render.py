"""Offscreen rendering for cameras: the OpenGL back-end (EGL, else OSMesa) and a renderer that
draws a scene from any pose with any field of view.

The back-end is chosen when the first camera renders (a session without cameras never touches
OpenGL): ``MUJOCO_GL=egl`` or ``osmesa`` in the environment picks one; otherwise EGL is tried,
then OSMesa (the first that gives a context is kept for the process). The GL vendor,
renderer and version strings are kept (:class:`RendererInfo`): recordings hold them, because
images are byte-identical only on the same renderer.

Cameras are drawn with MuJoCo's renderer (``mjv_updateScene`` + ``mjr_render``) after the
scene camera is placed at the sensor's pose with the sensor's frustum, so a camera needs no
camera element in the model. Shadows and reflections are off (software rendering speed), sites
are hidden. A model with a :data:`BACKGROUND` numeric (an SDF world's ``<scene><background>``,
set by the world loader) shows that colour where nothing is drawn, as a Gazebo camera does
(MuJoCo's own background is black; its skybox would be a surface in the depth image).
"""

from __future__ import annotations

import importlib
import math
import os
import threading
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from harness.sensors.errors import RenderBackendError

__all__ = [
    "BACKENDS",
    "BACKGROUND",
    "DEBIAN_PACKAGES",
    "OffscreenRenderer",
    "RendererInfo",
    "contexts_created",
]

BACKENDS = ("egl", "osmesa")
BACKGROUND = "harness:background"
"""The name of the model numeric holding the background colour (r, g, b in 0-1)."""
DEBIAN_PACKAGES = "libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 (EGL) or libosmesa6 (OSMesa)"
"""What to install on Debian/Ubuntu when no back-end works (``make system-deps`` does)."""

_created = 0
_lock = threading.Lock()


def contexts_created() -> int:
    """How many OpenGL contexts this process has created for sensors (0 without cameras)."""
    return _created


@dataclass(frozen=True)
class RendererInfo:
    """The OpenGL back-end and the driver's strings (recorded with images)."""

    backend: str
    vendor: str
    renderer: str
    version: str

    def to_metadata(self) -> dict[str, str]:
        """As recording metadata keys."""
        return {
            "gl_backend": self.backend,
            "gl_vendor": self.vendor,
            "gl_renderer": self.renderer,
            "gl_version": self.version,
        }


def _candidates() -> tuple[str, ...]:
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen in BACKENDS:
        return (chosen,)
    return BACKENDS


def _context(width: int, height: int) -> tuple[Any, str]:
    errors: list[str] = []
    for backend in _candidates():
        try:
            module = importlib.import_module(f"mujoco.{backend}")
            context = module.GLContext(width, height)
            context.make_current()
        except Exception as exc:  # any failure of a back-end means: try the next one
            errors.append(f"{backend}: {type(exc).__name__}: {exc}".splitlines()[0])
            continue
        return context, backend
    raise RenderBackendError(
        "no offscreen OpenGL for camera sensors (" + "; ".join(errors) + "): install the Debian "
        f"packages {DEBIAN_PACKAGES} (make system-deps does it as root), or set MUJOCO_GL"
    )


def _gl_strings() -> tuple[str, str, str]:
    from OpenGL import GL  # type: ignore[import-untyped]  # only once a context exists

    def text(name: int) -> str:
        value = GL.glGetString(name)
        return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)

    return text(GL.GL_VENDOR), text(GL.GL_RENDERER), text(GL.GL_VERSION)


class OffscreenRenderer:
    """One OpenGL context and MuJoCo render context for a model; renders any number of camera
    views up to ``width`` x ``height``. Use it from one thread."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int) -> None:
        global _created
        vis = model.vis.global_
        # The offscreen buffer must hold the largest camera; a visual-only setting.
        vis.offwidth = max(int(vis.offwidth), width)
        vis.offheight = max(int(vis.offheight), height)
        with _lock:
            self._gl, backend = _context(int(vis.offwidth), int(vis.offheight))
            _created += 1
        self.model = model
        mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, mjr)
        mjr.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._mjr: mujoco.MjrContext | None = mjr
        vendor, renderer, version = _gl_strings()
        self.info = RendererInfo(backend, vendor, renderer, version)
        self._option = mujoco.MjvOption()
        self._option.sitegroup[:] = 0
        self._free = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, self._free)
        self._background: npt.NDArray[np.uint8] | None = None
        index = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, BACKGROUND))
        if index >= 0 and int(model.numeric_size[index]) == 3:
            start = int(model.numeric_adr[index])
            color = np.clip(model.numeric_data[start : start + 3], 0.0, 1.0)
            self._background = np.round(color * 255).astype(np.uint8)

    def new_scene(self) -> mujoco.MjvScene:
        """A scene for one camera."""
        scene = mujoco.MjvScene(self.model, maxgeom=1000 + 2 * self.model.ngeom)
        scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        return scene

    def render(
        self,
        scene: mujoco.MjvScene,
        data: mujoco.MjData,
        position: npt.NDArray[np.float64],
        rotation: npt.NDArray[np.float64],
        vfov: float,
        near: float,
        far: float,
        rgb: npt.NDArray[np.uint8] | None,
        depth: npt.NDArray[np.float32] | None,
    ) -> None:
        """Draw ``data`` seen from ``position`` with ``rotation`` (columns: forward, left, up)
        into ``rgb`` (H x W x 3) and/or ``depth`` (H x W, metres along the optical axis,
        ``far`` where nothing was hit). Rows are top to bottom."""
        self._gl.make_current()
        model = self.model
        mujoco.mjv_updateScene(
            model, data, self._option, None, self._free, mujoco.mjtCatBit.mjCAT_ALL.value, scene
        )
        top = near * math.tan(vfov / 2)
        for cam in scene.camera:
            cam.pos[:] = position
            cam.forward[:] = rotation[:, 0]
            cam.up[:] = rotation[:, 2]
            cam.frustum_near = near
            cam.frustum_far = far
            cam.frustum_top = top
            cam.frustum_bottom = -top
            cam.frustum_center = 0.0
            cam.frustum_width = 0.0
            cam.orthographic = 0
        shape = (rgb if rgb is not None else depth).shape  # type: ignore[union-attr]
        rect = mujoco.MjrRect(0, 0, shape[1], shape[0])
        mujoco.mjr_render(rect, scene, self._mjr)
        background = self._background if rgb is not None else None
        depth_buffer = depth
        if depth_buffer is None and background is not None:  # tells where nothing was drawn
            depth_buffer = np.empty(shape[:2], np.float32)
        mujoco.mjr_readPixels(rgb, depth_buffer, rect, self._mjr)
        if rgb is not None:
            rgb[:] = rgb[::-1].copy()
            if background is not None and depth_buffer is not None:
                rgb[depth_buffer[::-1] <= 0.0] = background  # the cleared depth: nothing drawn
        if depth is not None:
            # Reversed-Z depth buffer (1 at near, 0 at far) back to metres.
            z = depth[::-1].astype(np.float64)
            depth[:] = (near * far / (near + z * (far - near))).astype(np.float32)

    def close(self) -> None:
        """Free the render and GL contexts."""
        if self._mjr is not None:
            self._gl.make_current()
            self._mjr.free()
            self._mjr = None
            self._gl.free()
