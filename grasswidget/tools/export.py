"""Animation export: render a GrassScene frame by frame into a GIF or an MP4.

The export is deterministic: it never looks at the wall clock. Each frame
advances the simulation by the same whole number of fixed steps,
``steps_per_frame = round(1 / (fps * params.dt))``, so the same start state
and parameters always give the same frames. With the default ``dt = 1/120`` s,
fps 10, 12, 15, 20, 24, 30, 40 and 60 map to exact real time; other rates are
rounded to whole steps (the film then plays slightly faster or slower than
real time; :func:`plan_animation` says by how much).

Frame 0 is the current state; frame k is the state after ``k *
steps_per_frame`` steps. The export starts from the scene's *current* state
(whatever the live view shows) and, with ``restore=True`` (default), puts that
state and the step counter back afterwards, so the live view is undisturbed
and two exports in a row give identical files.

What is deterministic: the simulation (checked bit-exact on lavapipe and on an
NVIDIA H200) and, on lavapipe, the frames. On a real GPU the culling pass
compacts the visible blades with atomics, so their draw order varies from run to
run and a few pixels per frame where two blades meet at exactly the same depth
may differ (measured on an H200, 640 x 480, 65k blades: 3-65 of 307,200 pixels);
GIF's per-frame palette can then spread such a difference over more pixels.

GIF is written with Pillow (through imageio); note that Pillow merges
consecutive frames that are pixel-identical (a meadow without wind) into one
longer frame. MP4 (H.264, yuv420p) needs ``imageio-ffmpeg`` and even frame
sizes.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..errors import GrassTypeError, GrassValueError, MissingDependencyError, MissingFileError

__all__ = ["save_animation", "plan_animation", "FORMATS", "MAX_FRAMES"]

#: Supported file suffixes.
FORMATS = (".gif", ".mp4")
#: Largest number of frames one export may have (seconds * fps).
MAX_FRAMES = 10_000


def plan_animation(dt, seconds, fps) -> dict:
    """Validate the timing arguments; returns frames, steps_per_frame and the
    simulated seconds per real second of the result (1.0 = real time)."""
    for name, value in (("seconds", seconds), ("fps", fps)):
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise GrassTypeError(f"{name} must be a number; got {value!r}")
        if not math.isfinite(float(value)) or float(value) <= 0:
            raise GrassValueError(f"{name} must be a finite number > 0; got {value!r}")
    seconds, fps = float(seconds), float(fps)
    if fps > 120:
        raise GrassValueError(f"fps must be at most 120; got {fps!r}")
    frames = int(round(seconds * fps))
    if frames < 1:
        raise GrassValueError(f"seconds * fps must give at least one frame; got {seconds} s at {fps} fps")
    if frames > MAX_FRAMES:
        raise GrassValueError(f"seconds * fps = {frames} frames; at most {MAX_FRAMES} frames per export")
    steps = int(round(1.0 / (fps * dt)))
    if steps < 1:
        raise GrassValueError(
            f"fps {fps:g} is faster than the simulation step (params.dt = {dt:g} s, at most {1 / dt:g} "
            "frames per simulated second): lower fps or params.dt"
        )
    return dict(frames=frames, steps_per_frame=steps, speed=steps * dt * fps, fps=fps)


def _check_path(path):
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in FORMATS:
        raise GrassValueError(f"path must end in one of {', '.join(FORMATS)}; got {path!r}")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise MissingFileError(f"folder {folder!r} of {path!r} does not exist")
    return path, ext


def _offscreen_renderer(size):
    from rendercanvas.offscreen import RenderCanvas

    from ..gpu.scene import make_renderer

    canvas = RenderCanvas(size=size, pixel_ratio=1)
    return canvas, make_renderer(canvas, export=True)  # anti-aliased, like save_png


def save_animation(scene, path, seconds=4.0, fps=20, size=None, progress=True, *, restore=True,
                   on_frame=None) -> str:
    """Render ``seconds * fps`` frames of ``scene`` and write them to ``path``.

    Args:
        scene: a :class:`grasswidget.GrassScene` (its camera and params are used).
        path: ``*.gif`` or ``*.mp4`` (MP4 needs imageio-ffmpeg).
        seconds: length of the film in seconds (> 0).
        fps: frames per second of the film (0 < fps <= 120; at most 1 / params.dt).
        size: (width, height) or "WxH" of the frames; default the scene's size.
            MP4 needs even width and height.
        progress: show a tqdm progress bar.
        restore: put the scene's state and step counter back afterwards (default).
        on_frame: optional callable ``on_frame(k, t)`` run before frame k is simulated and
            drawn (t: seconds of simulated time since the first frame), e.g. to move
            colliders (``scene.colliders.set_array(...)``); its changes apply to the
            steps that lead to frame k and are drawn in it.

    Returns the path written. Raises ValueError/TypeError for bad arguments
    before rendering anything.
    """
    from ..gpu.scene import parse_size

    path, ext = _check_path(path)
    size = scene.size if size is None else parse_size(size)
    params = scene.params
    plan = plan_animation(params.dt, seconds, fps)
    if ext == ".mp4":
        if size[0] % 2 or size[1] % 2:
            raise GrassValueError(f"MP4 (H.264, yuv420p) needs an even width and height; got size {size}")
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise MissingDependencyError("writing MP4 needs imageio-ffmpeg: pip install imageio-ffmpeg") from None
    if not isinstance(progress, bool):
        raise GrassTypeError(f"progress must be True or False; got {progress!r}")
    if on_frame is not None and not callable(on_frame):
        raise GrassTypeError(f"on_frame must be a callable on_frame(k, t) or None; got {on_frame!r}")

    from tqdm.auto import tqdm

    field = scene.field
    saved = field.read_state() if restore else None
    saved_steps = field.step_count
    canvas, renderer = _offscreen_renderer(size)
    canvas.request_draw(lambda: scene.draw_into(renderer))
    aspect = scene.camera.aspect
    writer = None
    frames = []
    try:
        if ext == ".mp4":
            import imageio.v2 as iio2

            writer = iio2.get_writer(path, format="FFMPEG", mode="I", fps=plan["fps"], codec="libx264",
                                     pixelformat="yuv420p", quality=8, macro_block_size=1)
        bar = tqdm(total=plan["frames"], disable=not progress, desc=os.path.basename(path), unit="frame")
        try:
            balls = getattr(scene, "collider_balls", None)
            for k in range(plan["frames"]):
                if on_frame is not None:
                    on_frame(k, k * plan["steps_per_frame"] * params.dt)
                if k:
                    field.step(plan["steps_per_frame"])
                if balls is not None:
                    balls.sync()
                rgb = np.ascontiguousarray(np.asarray(canvas.draw())[..., :3])
                if writer is not None:
                    writer.append_data(rgb)
                else:
                    frames.append(rgb)
                bar.update(1)
        finally:
            bar.close()
        if writer is None:
            import imageio.v3 as iio

            iio.imwrite(path, np.stack(frames), extension=".gif", duration=1000.0 / plan["fps"], loop=0)
    finally:
        if writer is not None:
            writer.close()
        scene.camera.aspect = aspect
        canvas.close()
        if restore:
            field.write_state(saved)
            # The wind time is derived from the step counter: put it back so the
            # wind continues where it was.
            field.step_count = saved_steps
    return path
