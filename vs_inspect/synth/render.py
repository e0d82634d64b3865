"""Off-screen rendering of a synth World with pyvista/VTK, through an exact OpenCV pinhole camera.

The scene is built once; every frame only moves the actors (user matrices) and the camera.

Camera model. OpenCV: x_cam = R X + t, u = fx x/z + cx, v = fy y/z + cy, x right, y down,
z forward, integer pixel coordinates at pixel centres. VTK's view frame is x right, y up,
looking down -z, so the view matrix is diag(1,-1,-1,1) · cam_from_world; that is what
position = C, focal point = C + z-axis, view-up = -y-axis gives. The projection is set as an
explicit OpenGL matrix built from K (so fx != fy and an off-centre principal point are exact):
NDC x = -1 is the left edge of pixel 0 (u = -0.5) and +1 the right edge of pixel W-1
(u = W - 0.5); NDC y = +1 is the top edge of row 0 (v = -0.5).
"""

from __future__ import annotations

import logging
import os

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402
import vtk  # noqa: E402
from vtk.util.numpy_support import vtk_to_numpy  # noqa: E402

from ..geometry.epipolar import camera_centers  # noqa: E402
from .meshes import Mesh  # noqa: E402
from .world import World  # noqa: E402

log = logging.getLogger(__name__)

NEAR_M = 0.05
FAR_M = 200.0


def opengl_projection(K: np.ndarray, width: int, height: int, near: float = NEAR_M,
                      far: float = FAR_M) -> np.ndarray:
    """(4,4) OpenGL projection (VTK view frame -> clip space) equivalent to the pinhole K."""
    fx, s, cx = K[0]
    fy, cy = K[1, 1], K[1, 2]
    W, H = float(width), float(height)
    P = np.zeros((4, 4))
    P[0, 0] = 2 * fx / W
    P[0, 1] = -2 * s / W  # VTK y is OpenCV -y
    P[0, 2] = 1 - (2 * cx + 1) / W
    P[1, 1] = 2 * fy / H
    P[1, 2] = (2 * cy + 1) / H - 1
    P[2, 2] = -(far + near) / (far - near)
    P[2, 3] = -2 * far * near / (far - near)
    P[3, 2] = -1.0
    return P


def zbuffer_to_depth(zbuf: np.ndarray, near: float = NEAR_M, far: float = FAR_M) -> np.ndarray:
    """Window depth in [0,1] -> distance along the optical axis (m, float32); inf where nothing
    was drawn. float32 keeps about 1e-6 relative precision, far below the depth buffer's own."""
    z_ndc = np.float32(2.0) * zbuf.astype(np.float32) - np.float32(1.0)
    with np.errstate(divide="ignore"):
        depth = np.float32(2 * far * near) / (np.float32(far + near) - z_ndc * np.float32(far - near))
    depth[zbuf >= 1.0] = np.inf
    return depth


def _polydata(mesh: Mesh) -> pv.PolyData:
    faces = np.hstack([np.full((len(mesh.faces), 1), 3), mesh.faces]).ravel()
    poly = pv.PolyData(mesh.points.copy(), faces)
    poly.active_texture_coordinates = mesh.uv.astype(np.float32)
    poly.point_data["Normals"] = mesh.normals.astype(np.float32)
    poly.point_data.active_normals_name = "Normals"
    return poly


def _vtk_matrix(T: np.ndarray) -> vtk.vtkMatrix4x4:
    m = vtk.vtkMatrix4x4()
    m.DeepCopy(np.ascontiguousarray(T, dtype=np.float64).ravel())
    return m


class SceneRenderer:
    """Renders a World from any camera (K, cam_from_world) at any global time.

    segmentation=True draws every body in its flat id colour (no lighting, no texture, no
    anti-aliasing), for tests and masks. multi_samples > 1 turns on MSAA (smoother edges; on
    Mesa llvmpipe it costs render time).
    """

    def __init__(self, world: World, width: int, height: int, segmentation: bool = False,
                 anti_aliasing: bool = False, multi_samples: int = 1):
        self.world = world
        self.segmentation = segmentation
        self.size = (int(width), int(height))
        self.plotter = pv.Plotter(off_screen=True, window_size=self.size, lighting="none")
        pl = self.plotter
        pl.ren_win.SetMultiSamples(0 if segmentation or multi_samples <= 1 else int(multi_samples))
        if segmentation:
            pl.set_background((0, 0, 0))
        else:
            pl.set_background((0.62, 0.78, 0.95), top=(0.25, 0.45, 0.8))
            sun = pv.Light(position=(6.0, -4.0, 10.0), focal_point=(0.0, 0.0, 0.0),
                           light_type="scene light", intensity=0.75)
            fill = pv.Light(position=(-8.0, 6.0, 5.0), focal_point=(0.0, 0.0, 0.0),
                            light_type="scene light", intensity=0.25)
            pl.add_light(sun)
            pl.add_light(fill)
            if anti_aliasing:  # EGL builds fall back to SSAA: much slower
                pl.enable_anti_aliasing("ssaa")
        self.actors: list[tuple[int, vtk.vtkActor]] = []
        for i, body in enumerate(world.bodies):
            poly = _polydata(body.mesh)
            if segmentation:
                actor = pl.add_mesh(poly, color=body.id_rgb, lighting=False, smooth_shading=False)
                prop = actor.GetProperty()
                prop.LightingOff()
                prop.SetAmbient(1.0)
                prop.SetDiffuse(0.0)
                prop.SetSpecular(0.0)
            else:
                tex = pv.Texture(np.ascontiguousarray(body.texture))  # pyvista takes row 0 = top
                tex.interpolate = True
                tex.mipmap = True
                actor = pl.add_mesh(poly, texture=tex, smooth_shading=True, ambient=0.45,
                                    diffuse=0.65, specular=0.0)
            actor.SetUserMatrix(_vtk_matrix(np.eye(4)))
            if body.moving:
                self.actors.append((i, actor))
        pl.camera_set = True
        self.ren_win = pl.ren_win
        self.camera = pl.renderer.GetActiveCamera()
        self.camera.SetUseExplicitProjectionTransformMatrix(True)
        self.camera.SetClippingRange(NEAR_M, FAR_M)
        self.ren_win.SetSize(*self.size)

    def set_size(self, width: int, height: int) -> None:
        self.size = (int(width), int(height))
        self.ren_win.SetSize(*self.size)

    def set_time(self, g: float) -> None:
        """Move every moving body to its pose at global time g (s)."""
        for i, actor in self.actors:
            T = self.world.bodies[i].world_from_body(np.array([g]))[0]
            actor.SetUserMatrix(_vtk_matrix(T))

    def set_camera(self, K: np.ndarray, cam_from_world: np.ndarray) -> None:
        R, C = cam_from_world[:3, :3], camera_centers(cam_from_world)
        cam = self.camera
        cam.SetPosition(*C)
        cam.SetFocalPoint(*(C + R[2]))
        cam.SetViewUp(*(-R[1]))
        cam.SetExplicitProjectionTransformMatrix(_vtk_matrix(opengl_projection(K, *self.size)))

    def render(self, g: float, K: np.ndarray, cam_from_world: np.ndarray, depth: bool = True
               ) -> tuple[np.ndarray, np.ndarray | None]:
        """((H,W,3) uint8 RGB, row 0 = top; (H,W) depth along the optical axis in m or None)."""
        self.set_time(g)
        self.set_camera(K, cam_from_world)
        W, H = self.size
        self.ren_win.Render()
        arr = vtk.vtkUnsignedCharArray()
        self.ren_win.GetPixelData(0, 0, W - 1, H - 1, 0, arr, 0)
        rgb = vtk_to_numpy(arr).reshape(H, W, -1)[::-1, :, :3]
        dmap = None
        if depth:
            z = vtk.vtkFloatArray()
            self.ren_win.GetZbufferData(0, 0, W - 1, H - 1, z)
            dmap = zbuffer_to_depth(vtk_to_numpy(z).reshape(H, W)[::-1])
        return np.ascontiguousarray(rgb), dmap

    def close(self) -> None:
        self.plotter.close()

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
