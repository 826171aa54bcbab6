"""Write a live page: one self-contained HTML file that runs the meadow in any browser with WebGPU.

``GrassWidget.save_html(path)`` and ``python -m grasswidget html OUT.html`` end
here. The page (see :mod:`grasswidget.browser.page`) carries the browser engine,
the WGSL, the blades and the current parameters and camera; in a browser without
WebGPU it shows a still picture of the same view, rendered here in the kernel
engine (a :class:`~grasswidget.gpu.scene.GrassScene` with the same camera), and one
line saying WebGPU is needed.

Limits (checked before anything is built): the name must end in ``.html``, its
folder must exist, at most :data:`~grasswidget.browser.page.PAGE_MAX_BLADES`
blades (64 bytes each, base64 in the file).
"""

from __future__ import annotations

import io

from ..browser.page import PAGE_MAX_BLADES, check_page_blades, check_page_path, page_html
from ..core.blades import Blades
from ..core.params import GrassParams
from ..errors import GrassTypeError

__all__ = ["save_html", "still_picture", "PAGE_MAX_BLADES", "STILL_STEPS"]

#: Fixed simulation steps (of params.dt) before the still picture is taken (1 s at 120 steps/s).
STILL_STEPS = 120


def still_picture(blades: Blades, params: GrassParams, camera: dict, size, colliders=(), steps: int = STILL_STEPS,
                  show_colliders: bool = True):
    """PNG bytes of the kernel engine's picture of ``blades`` after ``steps`` fixed steps,
    seen by ``camera`` ({position, target, fov_deg, near, far}) at ``size`` (w, h)."""
    import imageio.v3 as iio

    from ..gpu.scene import GrassScene

    scene = GrassScene(blades, size=tuple(size), params=params.copy())
    try:
        scene.camera.depth_range = (float(camera.get("near", 0.1)), float(camera.get("far", 100.0)))
        scene.look(camera["position"], camera["target"], camera.get("fov_deg"))
        scene.colliders = list(colliders)
        scene.show_colliders = bool(show_colliders)
        scene.step(int(steps))
        img = scene.render()
    finally:
        scene.release()
    buf = io.BytesIO()
    iio.imwrite(buf, img, extension=".png")
    return buf.getvalue()


def save_html(path, blades, params: GrassParams | None = None, *, size=(640, 480), camera: dict | None = None,
              colliders=(), ball_radius=None, playing: bool = True, time_scale: float = 1.0, still: bool = True,
              title: str = "grasswidget meadow", camera_floor: str | None = None) -> str:
    """Write the live page to ``path`` (must end in .html, in an existing folder); returns the path.

    Args:
        blades: a :class:`Blades` or a blade count (1 .. PAGE_MAX_BLADES; ``Blades.on_plane``).
        params: the :class:`GrassParams` to start from (copied; default a new one).
        size: (width, height) of the view in CSS pixels.
        camera: {position, target, fov_deg, near, far} (default: GrassScene's default view).
        colliders: spheres in the field at the start (the first one becomes the page's ball).
        ball_radius: radius (m) of the page's ball (default: the first collider's, else a
            tenth of the field's extent).
        playing, time_scale: the page's clock at the start.
        still: render the still picture shown without WebGPU (False: the line alone).
        camera_floor: what the page's orbit keeps the camera above, "grass" or "ground"
            (default: "grass" unless the camera is lower than the grass, as the cis565 view).
    """
    from ..browser.engine_widget import BrowserEngineWidget
    from ..core.camera_presets import floor_for
    from ..core.orbit_limits import check_floor

    p = check_page_path(path)
    if isinstance(blades, (int,)) and not isinstance(blades, bool):
        blades = Blades.on_plane(check_page_blades(blades))
    if not isinstance(blades, Blades):
        raise GrassTypeError(f"blades must be a Blades or a blade count, not {type(blades).__name__}")
    check_page_blades(len(blades))
    if params is not None and not isinstance(params, GrassParams):
        raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
    params = (params or GrassParams()).copy()
    colliders = list(colliders)
    if ball_radius is None and colliders:
        ball_radius = float(colliders[0].radius)
    view = BrowserEngineWidget(blades, params=params, size=tuple(size), camera=camera)
    try:
        view.camera_floor = (check_floor(camera_floor) if camera_floor is not None
                             else floor_for(blades, view.camera, view.camera.get("far")))
        view.playing = bool(playing)
        view.time_scale = float(time_scale)
        view.colliders = colliders[:1]
        png = still_picture(blades, params, view.camera, (view.width, view.height), colliders[:1]) if still else None
        text = page_html(view, title=title, still_png=png, ball_radius=ball_radius, ball_enabled=bool(colliders))
    finally:
        view.close()
    p.write_text(text, encoding="utf-8")
    return str(p)
