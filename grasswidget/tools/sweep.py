"""Parameter sweeps: one meadow rendered for each setting of one or two parameters.

::

    import grasswidget as gw
    s = gw.sweep({"stiffness_scale": [0.25, 0.5, 1, 2, 4]}, steps=240, blades=4096)
    s                      # in a notebook: the picture, one labelled cell per setting
    s.data["mean_tip_offset"]   # (5,) metres, one per setting
    s.save("stiffness.png")

Each setting starts from the same blades at rest, with the same camera, and is
stepped the same number of fixed steps by the kernel engine (a
:class:`~grasswidget.gpu.scene.GrassScene`, headless); then the blade state is read
back (mean tip offset and mean bend, :mod:`grasswidget.core.blade_response`) and the
view rendered anti-aliased (``GrassScene.render_at``) and counted (blades drawn, as
``GrassScene.visible_count``). One scene is made and reused: before each setting its
blades go back to rest (``GrassField.reset``, which also sets the wind's clock to 0)
and its parameters are set afresh from the base, so every cell is what a new
``GrassScene`` with those parameters shows after ``steps`` steps (tested).

One parameter gives a row (the values left to right), two a grid (the first
parameter down, the second across). Bad input (an unknown parameter, a value out of
range, an empty sweep, more than two parameters, more than
:data:`~grasswidget.core.variants.MAX_SWEEP_CELLS` settings) raises before any GPU work
(:mod:`grasswidget.core.variants`). From a shell: ``python -m grasswidget sweep``.
"""

from __future__ import annotations

import io

import numpy as np

from ..core.limits import MAX_STEPS
from ..core.blade_response import response_summary
from ..core.blades import Blades
from ..core.presets import PRESETS, check_png_path, parse_size
from ..core.params import GrassParams
from ..core.variants import apply_changes, check_sweep_axes
from ..errors import GrassTypeError, GrassValueError
from .sheet import labelled_sheet

__all__ = ["sweep", "SweepResult", "METRICS", "DEFAULT_BLADES", "DEFAULT_SIZE", "MAX_CELL_PIXELS"]

#: The numbers measured per cell (keys of ``SweepResult.data``): metres, degrees, a count.
METRICS = ("mean_tip_offset", "mean_bend_deg", "blades_drawn")
#: Blades of a sweep's field by default.
DEFAULT_BLADES = 4096
#: Size (w, h) of one cell's picture in pixels by default.
DEFAULT_SIZE = (240, 180)
#: The most pixels one cell's picture may have (1920 x 1080).
MAX_CELL_PIXELS = 1920 * 1080


def _value_text(value) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return "(" + ", ".join(_value_text(v) for v in value) + ")"
    return str(value)


class SweepResult:
    """What :func:`sweep` returns: the picture and the numbers of every setting.

    Attributes:
        image: (H, W, 4) uint8 RGBA: the labelled row or grid (shown by a notebook,
            written by :meth:`save`).
        cells: (rows, cols, h, w, 4) uint8 RGBA: each setting's picture alone.
        data: dict of NumPy arrays: each swept parameter's values (``data[name]``, 1-D,
            in order), and per cell ``mean_tip_offset`` (m), ``mean_bend_deg``
            (degrees) and ``blades_drawn`` (count), each of shape (n,) for a row or
            (n_rows, n_cols) for a grid.
        axes: the swept parameters in order, {name: [values]} (the first is the rows of
            a grid, or the row).
        steps: fixed steps each setting was simulated (of its own ``params.dt``).
        dt: the fixed step (s) every setting used, or None when ``dt`` is swept.
        blades: blades in the field.
    """

    def __init__(self, axes, cells, metrics, steps, blades, dt=None):
        self.axes = {k: list(v) for k, v in axes.items()}
        self.steps, self.blades = int(steps), int(blades)
        self.dt = None if dt is None or "dt" in self.axes else float(dt)
        self.cells = cells
        names = list(self.axes)
        self.data = {}
        for name in names:
            values = self.axes[name]
            self.data[name] = np.asarray(values, np.float64) if all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in values) else np.asarray(values)
        squeeze = len(names) == 1
        for key in METRICS:
            a = metrics[key]
            self.data[key] = a[0] if squeeze else a
        self.image = _sheet(self)

    @property
    def shape(self) -> tuple:
        """(rows, cols) of the grid (a row: (1, n))."""
        return tuple(self.cells.shape[:2])

    def save(self, path) -> str:
        """Write :attr:`image` as a PNG (the name must end in .png; a missing folder is
        not created: MissingFileError). Returns the path."""
        from PIL import Image

        path = check_png_path(path)
        Image.fromarray(self.image, "RGBA").save(path)
        return path

    def _repr_png_(self):
        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(self.image, "RGBA").save(buf, format="PNG")
        return buf.getvalue()

    def __repr__(self):
        axes = " x ".join(f"{name} ({len(v)})" for name, v in self.axes.items())
        return f"<SweepResult {axes}: {self.blades} blades, {self.steps} steps, image {self.image.shape[1]}x{self.image.shape[0]}>"


def _sheet(result) -> np.ndarray:
    """The labelled picture (:func:`grasswidget.tools.sheet.labelled_sheet`): a title, column
    labels over the cells, row labels left of them (a grid), and under each cell its mean
    tip offset and bend."""
    names = list(result.axes)
    col_name = names[-1]
    row_name = names[0] if len(names) == 2 else None
    title = f"{result.blades} blades after {result.steps} steps"
    if result.dt is not None:
        title += f" ({result.steps * result.dt:.2f} s)"
    tips = np.atleast_2d(result.data["mean_tip_offset"])
    bends = np.atleast_2d(result.data["mean_bend_deg"])
    rows, cols = tips.shape
    notes = [[f"tip {tips[r, c]:.3f} m · bend {bends[r, c]:.1f}°" for c in range(cols)] for r in range(rows)]
    return labelled_sheet(result.cells, title=title,
                          col_labels=[f"{col_name} = {_value_text(v)}" for v in result.axes[col_name]],
                          row_labels=[f"{row_name} = {_value_text(v)}" for v in result.axes[row_name]] if row_name else [],
                          notes=notes)


def _check_args(steps, blades, preset, size, params):
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or not (0 <= steps <= MAX_STEPS):
        raise GrassValueError(f"steps must be an integer in [0, {MAX_STEPS}] (fixed steps of params.dt; "
                              f"MAX_STEPS, grasswidget.core.limits); got {steps!r}")
    if preset is not None and preset not in PRESETS:
        raise GrassValueError(f"preset must be None or one of {', '.join(PRESETS)}; got {preset!r}")
    if not isinstance(blades, Blades):
        if isinstance(blades, bool) or not isinstance(blades, (int, np.integer)) or blades < 1:
            raise GrassValueError(f"blades must be a blade count >= 1 or a grasswidget.Blades; got {blades!r}")
        from ..core.memory import check_blade_count

        check_blade_count(int(blades))  # host memory, before anything is made
    size = parse_size(size)
    if size[0] * size[1] > MAX_CELL_PIXELS:
        raise GrassValueError(f"size: a cell has at most {MAX_CELL_PIXELS} pixels (1920x1080); got {size[0]}x{size[1]}")
    if params is not None and not isinstance(params, GrassParams):
        raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
    return size


def sweep(axes, steps=240, blades=DEFAULT_BLADES, preset=None, size=DEFAULT_SIZE, params=None, seed=0,
          progress=True) -> SweepResult:
    """Render one meadow per setting of one or two parameters, after the same steps.

    Args:
        axes: {GrassParams trait name: [values]}: one parameter (a row) or two (a grid:
            the first down, the second across); e.g. ``{"stiffness_scale": [0.5, 1, 2]}``.
        steps: fixed steps of ``params.dt`` simulated for each setting (default 240,
            2 s at the default dt; 0..1e6).
        blades: a blade count (``Blades.on_plane(count, seed=seed)``, or the preset's
            field) or a :class:`Blades` (default 4096).
        preset: None or a ``GrassScene.preset`` name ("cis565", "meadow"): its field and
            camera.
        size: (w, h) or "WxH" of each cell's picture in pixels (default 240 x 180).
        params: the base :class:`GrassParams` the swept values are set on (not
            changed; default: what the scene would make, e.g. the cis565 preset's).
        seed: seed of the blades when ``blades`` is a count.
        progress: show a progress bar (tqdm; a widget in a notebook).

    Returns a :class:`SweepResult` (``.image``, ``.data``, ``.save(path)``; shows as a
    picture in a notebook).
    """
    from tqdm.auto import tqdm

    axes = check_sweep_axes(axes, params)
    size = _check_args(steps, blades, preset, size, params)

    from ..gpu.field import check_blade_count_fits
    from ..gpu.scene import CIS565_DISTANCE_MAX, GrassScene, adapter_params

    if not isinstance(blades, Blades):
        check_blade_count_fits(int(blades), "blades")
    if params is not None:
        base = params.copy()
    elif preset == "cis565":
        base = adapter_params(cull_distance_max=CIS565_DISTANCE_MAX)
    else:
        base = adapter_params()
    base_values = base.values()
    names = list(axes)
    row_values = axes[names[0]] if len(names) == 2 else [None]
    col_values = axes[names[-1]]
    settings = [[({names[0]: rv} if rv is not None else {}) | {names[-1]: cv} for cv in col_values]
                for rv in row_values]

    scene_params = base.copy()
    if preset is not None:
        scene = GrassScene.preset(preset, blades=blades, size=size, params=scene_params, seed=seed)
    else:
        field = blades if isinstance(blades, Blades) else Blades.on_plane(int(blades), seed=seed)
        scene = GrassScene(field, size=size, params=scene_params)
    rows, cols = len(row_values), len(col_values)
    w, h = size
    cells = np.zeros((rows, cols, h, w, 4), np.uint8)
    metrics = {"mean_tip_offset": np.zeros((rows, cols)), "mean_bend_deg": np.zeros((rows, cols)),
               "blades_drawn": np.zeros((rows, cols), np.int64)}
    bar = tqdm(total=rows * cols, desc="sweep", unit="setting", disable=not progress)
    try:
        for r in range(rows):
            for c in range(cols):
                changes = settings[r][c]
                bar.set_postfix_str(", ".join(f"{k}={_value_text(v)}" for k, v in changes.items()), refresh=False)
                for name, value in base_values.items():  # the base again: the last cell's values undone
                    if getattr(scene.params, name) != value:
                        setattr(scene.params, name, value)
                apply_changes(scene.params, changes, where="sweep")
                scene.field.reset()
                scene.step(int(steps))
                summary = response_summary(scene.field.read_state())
                cells[r, c] = scene.render_at(size)
                metrics["mean_tip_offset"][r, c] = summary["mean_tip_offset"]
                metrics["mean_bend_deg"][r, c] = summary["mean_bend_deg"]
                metrics["blades_drawn"][r, c] = scene.visible_count()
                bar.update(1)
    finally:
        bar.close()
        count = scene.field.count
        scene.release()
    return SweepResult(axes, cells, metrics, steps, count, dt=base.dt)
