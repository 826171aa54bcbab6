"""What a GrassWidget writes to files: pictures, animations and live pages.

Each function takes the live view (an :class:`~grasswidget.views.api.EngineView`) and what
the file needs; the widget's ``save_png``, ``save_animation`` and ``save_html`` (and the
panel's Save PNG button) call them. A PNG without a path goes to ``output/`` beside the
notebook (:func:`default_picture_folder`) under a name with the date and time.
"""

from __future__ import annotations

import datetime
import os

from ..core.presets import check_png_path, parse_size
from ..views import engines

__all__ = ["PICTURE_FOLDER", "default_picture_folder", "unique_name", "save_png", "save_png_later",
           "save_animation", "save_html"]

#: Where Save PNG and ``save_png()`` without a path write: this folder under the working
#: directory (the notebook's folder in Jupyter), as the notebooks save their pictures.
PICTURE_FOLDER = "output"


def default_picture_folder() -> str:
    """``output/`` under the current working directory (created if missing): where Save PNG
    and ``GrassWidget.save_png()`` without a path write."""
    folder = os.path.join(os.getcwd(), PICTURE_FOLDER)
    os.makedirs(folder, exist_ok=True)
    return folder


def unique_name(folder, stem, ext) -> str:
    """``folder/stem-YYYYmmdd-HHMMSS.ext``, with ``-2``, ``-3`` ... added while that file exists."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = os.path.join(folder, f"{stem}-{stamp}{ext}")
    k = 2
    while os.path.exists(path):
        path = os.path.join(folder, f"{stem}-{stamp}-{k}{ext}")
        k += 1
    return path


def save_png(view, path, size=None) -> str:
    """Write a PNG of ``view`` at ``size`` ((w, h) or "WxH"; None: twice the view's size) to ``path``
    (None: a new name in :func:`default_picture_folder`), waiting for it; return the path."""
    size = parse_size(size) if size is not None else (2 * view.size[0], 2 * view.size[1])
    if path is None:
        path = unique_name(default_picture_folder(), "grass", ".png")
    path = check_png_path(path)
    return view.snapshot(path, size).result()


def save_png_later(view, size, done, on_error) -> bool:
    """The Save PNG button: write a PNG of ``size`` into :func:`default_picture_folder` without
    blocking the kernel, then call ``done(path)`` (or ``on_error(err)``). Returns True."""
    path = unique_name(default_picture_folder(), "grass", ".png")

    def written(future):
        err = future.exception()
        if err is None:
            done(future.result())
        else:
            on_error(err)

    view.snapshot(path, size).add_done_callback(written)
    return True


def save_animation(view, path, view_size, camera, params, **film) -> str:
    """Film ``view`` with the kernel engine (:func:`grasswidget.tools.export.save_animation`: GIF, or
    MP4 with imageio-ffmpeg; ``film``: seconds, fps, size, progress, on_frame). It starts from the
    current state and puts the live state back afterwards; ``on_frame(k, t)`` runs before each
    frame (with the kernel engine it may move ``w.scene.colliders``, which the film's scene is).
    A browser view's current blade state is read back and a kernel scene (which needs a WebGPU
    adapter in the kernel, lavapipe will do) films it from ``camera``; the browser's own animation
    is not disturbed. Returns the path."""
    from ..tools.export import save_animation as film_scene

    if view.backend == "kernel":
        out = film_scene(view.scene, path, **film)
        view.request_draw()
        return out
    with engines.kernel_film_scene(view, view_size, params, camera) as scene:
        return film_scene(scene, path, **film)


def save_html(view, path, *, size, params, ball, playing, time_scale, still, title, camera_floor) -> str:
    """Write a live page of ``view``: one self-contained HTML file that runs the meadow in any browser
    with WebGPU, with no Python and no kernel (:mod:`grasswidget.tools.html_export`). The page carries
    the browser engine, the WGSL and the blades, and starts from the current parameters, camera,
    ball and play state; it offers orbit, play / pause, wind and culling controls, colour by and
    the ball (shift + drag). In a browser without WebGPU it shows a still picture of the same view
    (rendered now in the kernel engine, about a second on a CPU adapter; ``still=False`` leaves it
    out) and one line saying WebGPU is needed. ``path`` must end in .html in an existing folder,
    at most ``grasswidget.browser.page.PAGE_MAX_BLADES`` blades (GrassValueError, MissingFileError).
    Returns the path."""
    from ..tools.html_export import save_html as write_page

    engines.check_live_page(path, len(view.blades))
    near, far = view.readings.depth_range
    cam = view.camera_state
    camera = {"position": list(cam["position"]), "target": list(cam["target"]), "fov_deg": float(cam["fov_deg"]),
              "near": near, "far": far}
    colliders = [ball.collider] if ball is not None and ball.enabled else []
    return write_page(path, view.blades, params, size=size, camera=camera, colliders=colliders,
                      ball_radius=float(ball.collider.radius) if ball is not None else None,
                      playing=bool(playing), time_scale=float(time_scale), still=still, title=title,
                      camera_floor=camera_floor)
