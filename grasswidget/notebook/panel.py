"""The GrassWidget's control panel: sliders, toggles, buttons, the stats line.

:class:`ControlPanel` builds the ipywidgets controls and links them, both ways,
to traits: the :class:`~grasswidget.GrassParams` sliders, dropdown and culling
checkboxes to ``params``; the ``time_scale`` slider to the widget's state.
It knows nothing of how the meadow is drawn: buttons call actions
(``toggle_play``, ``step``, ``reset_blades``, ``reset_camera``, ``set_blades``,
and a save function), and the view hands it a stats dict to show with
:meth:`ControlPanel.show_stats`. So any view (the kernel's jupyter-rfb stream or
another engine) can sit above the same panel.

A control given a value its trait refuses snaps back and the message line says
why (see :class:`~grasswidget.notebook.control_link.ControlLink`).

Labels are words with units (:data:`LABELS`, :func:`control_label`), tooltips
the traits' help and range. The "looks" row: colour variety, patch size, dry
grass, sunlit tips, fog, the sun's height and direction (:data:`LOOK_SLIDERS`) and the shadows'
switch. Under the view, a one-line
status (frames/s, blades drawn, real time or slow motion) and a "details" toggle
for the frame's timings.

The teaching row: a "colour by" dropdown (``params.color_by``), a "freeze
culling" checkbox (the widget's ``culling_frozen`` trait), the legend of the
active colouring, and the inspected blade's numbers with a "Clear" button
(ctrl + click on a blade in the view inspects it). A view that cannot do one of
these says so on the message line (``show_unsupported``).
"""

from __future__ import annotations

import html

import ipywidgets as ipw

from .blade_count_control import BladeCountControl
from .control_link import ControlLink
from .layout import close_widgets
from .switch_choice import SWITCH_CHOICES, SwitchChoice
from ..core.params import COLOR_BY, WIND_FIELDS
from ..core.reference import FORCE_NAMES
from ..core.teaching import INSPECTED_BLADE_COLORS, legend

__all__ = ["ControlPanel", "PARAM_SLIDERS", "LOOK_SLIDERS", "LABELS", "CULL_CHECKBOXES", "control_label",
           "control_tooltip", "format_status", "format_speed", "format_age", "format_details", "legend_html", "inspected_html"]

#: Sliders of the panel: (GrassParams trait, slider step, readout format).
PARAM_SLIDERS = (
    ("wind_strength", 0.5, ".1f"),
    ("wind_direction", 1.0, ".0f"),
    ("wind_speed", 0.1, ".1f"),
    ("gravity", 0.1, ".1f"),
    ("stiffness_scale", 0.01, ".2f"),
)

#: The "looks" row: (GrassParams trait, slider step, readout format).
LOOK_SLIDERS = (
    ("color_variation", 0.05, ".2f"),
    ("patch_size", 0.1, ".1f"),
    ("dryness", 0.05, ".2f"),
    ("translucency", 0.05, ".2f"),
    ("fog_density", 0.001, ".3f"),
    ("sun_elevation", 1.0, ".0f"),
    ("sun_azimuth", 1.0, ".0f"),
)

#: What the panel calls each control, in words a student reads; the unit (from the
#: trait's ``unit``, see :func:`control_label`) is added in brackets. The one table
#: of the panel's labels.
LABELS = {
    "blades": "blades",
    "wind_strength": "wind strength",
    "wind_direction": "wind direction",
    "wind_speed": "gust speed",
    "gravity": "gravity",
    "stiffness_scale": "stiffness ×",
    "time_scale": "time",
    "wind_field": "wind pattern",
    "color_variation": "colour variety",
    "patch_size": "patch size",
    "dryness": "dry grass",
    "sun_elevation": "sun height",
    "sun_azimuth": "sun direction",
    "shadows": "shadows",
    "translucency": "sunlit tips",
    "fog_density": "fog",
    "color_by": "colour by",
}

#: How the panel writes the traits' units.
UNIT_TEXT = {"m/s^2": "m/s²", "degrees": "°", "simulated s per s": "× real time", "1/m^2": "1/m²"}


def control_label(name, trait=None) -> str:
    """The label of the control of trait ``name``: :data:`LABELS`' words plus the
    trait's unit in brackets, e.g. ``"wind strength (m/s²)"``."""
    words = LABELS.get(name, name.replace("_", " "))
    unit = getattr(trait, "unit", "") or ""
    return f"{words} ({UNIT_TEXT.get(unit, unit)})" if unit else words


def control_tooltip(name, trait) -> str:
    """The tooltip of a control: the trait's help and, for a ranged trait, its range."""
    text = (getattr(trait, "help", "") or control_label(name, trait)).strip()
    lo, hi = getattr(trait, "lo", None), getattr(trait, "hi", None)
    if lo is not None and hi is not None:
        unit = getattr(trait, "unit", "") or ""
        text += f" Range {lo:g} to {hi:g}{' ' + UNIT_TEXT.get(unit, unit) if unit else ''}."
    return text

#: Checkboxes of the panel: (label, GrassParams trait).
CULL_CHECKBOXES = (
    ("orientation culling", "cull_orientation"),
    ("frustum culling", "cull_frustum"),
    ("distance culling", "cull_distance"),
    ("LOD", "lod"),
)

_DESC = {"description_width": "140px"}
#: Width (CSS px) of one column of controls: two columns (and their margins) fill a 640 px view.
COLUMN_WIDTH = 314


def _column_width(view_width) -> str:
    """A control's width: one column, never wider than the view."""
    return f"{max(120, min(COLUMN_WIDTH, int(view_width) - 8))}px"


def _wrapping_row(children, **layout):
    """A row as wide as the view; what does not fit goes on to the next line."""
    return ipw.HBox(children, layout=ipw.Layout(width="100%", flex_flow="row wrap", align_items="center", **layout))


#: Frames/s below which the status says no frame arrives (it would read "0.0 frames/s").
NO_FRAMES_BELOW = 0.05


def format_speed(speed: float) -> str:
    """Simulated seconds per wall second as the status writes it: ``"0.6x"``, and two
    significant digits below 0.1 (``"0.03x"``), never ``"0.0x"``; a speed just under
    real time keeps two decimals (``"0.96x"``), never rounding up to ``"1.0x"``."""
    if speed >= 0.1:
        text = f"{speed:.1f}"
        if speed < 1.0 and float(text) >= 1.0:
            text = f"{min(speed, 0.99):.2f}"
        return f"{text}x"
    return f"{speed:.1g}x" if speed >= 0.01 else "under 0.01x"


def format_age(seconds: float) -> str:
    """Wall seconds as the status writes an age: ``"0.8 s"``, ``"12 s"``, ``"3 min"``."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.0f} min"


def format_status(stats: dict) -> str:
    """The one-line status under the view, in words (plain, " · " separated): frames
    per second, blades drawn, and whether time runs in real time or slow motion.
    Keys of a view's stats dict (each optional, None = unknown): ``fps``,
    ``visible``, ``blades``, ``slow_motion`` and ``sim_speed`` (simulated / wall
    seconds), ``playing`` (False: "paused" instead of the speed of time), and how old
    the numbers are (:func:`grasswidget.core.engine_inputs.stats_freshness`): ``at_rest``,
    ``waiting``, ``stale`` and ``frame_age_s``. The rest is in :func:`format_details`.

    It only says what it knows: paused, ``"paused"`` (no frame rate: a paused view
    draws on demand; ``"paused, out of sight"`` at rest); out of sight, ``"at rest (out of sight)"``; playing before the first
    measured frame (``fps`` None), ``"starting…"``; playing while no frame arrives
    (``waiting``: none for :data:`~grasswidget.core.engine_inputs.WAITING_AFTER_S`; without
    that key, ``fps`` below :data:`NO_FRAMES_BELOW`), ``"waiting for frames"``, and never
    while frames arrive. Stale numbers say their age: ``"last frame 12 s ago"``.
    "real time" or "slow motion" only follow a measured frame rate of fresh stats, and not
    while ``sim_speed`` is given as None (the speed of simulated time is not measured yet)."""
    s = stats
    fps = s.get("fps")
    aged = "waiting" in s  # the stats say how old they are (both engines' views do)
    measured = fps is not None and fps >= NO_FRAMES_BELOW
    if s.get("playing") is False:
        parts = ["paused, out of sight" if s.get("at_rest") else "paused"]
    elif s.get("at_rest"):
        parts = ["at rest (out of sight)"]
    elif s.get("waiting") or (not aged and fps is not None and not measured):
        parts = ["waiting for frames"]
    elif fps is None or not measured:
        parts = ["starting…"]  # (with an age: frames arrive, their rate is not measured yet)
    else:
        parts = [f"{fps:.1f} frames/s"]
    blades = s.get("blades")
    if s.get("visible") is not None and blades is not None:
        parts.append(f"{s['visible']:,} of {blades:,} blades drawn")
    elif blades is not None:
        parts.append(f"{blades:,} blades")
    fresh = not (s.get("stale") or s.get("at_rest") or s.get("waiting"))
    if s.get("playing") is not False and measured and fresh:
        if s.get("slow_motion") and s.get("sim_speed") is not None:
            parts.append(f"slow motion {format_speed(s['sim_speed'])}")
        elif "sim_speed" not in s or s["sim_speed"] is not None:  # not measured yet: no claim
            parts.append("real time")
    if s.get("stale") and s.get("frame_age_s") is not None:
        parts.append(f"last frame {format_age(s['frame_age_s'])} ago")
    return " · ".join(parts)


def format_details(stats: dict) -> str:
    """The detailed timings behind the "details" toggle (plain, " · " separated).

    Known keys (each optional, None = unknown): ``fps`` (frames/s delivered) and
    ``target_fps``; ``visible``, ``rastered`` (of the visible, drawn by the compute
    rasterizer) and ``occluded`` (blades culled by occlusion); the stages of a frame in
    ms: ``render_ms`` (steps + render submit), ``readback_ms``, ``encode_ms`` (JPEG, on a
    worker thread), ``send_ms``, ``ack_ms`` (send to the browser's acknowledgement);
    ``unchanged_fps`` (frames/s not sent again as unchanged); ``draw_ms`` (shown when the
    stages are unknown); ``gpu_ms`` (dict pass -> ms); ``scale`` (render scale of the
    pixel ratio) and ``frame_size`` ((w, h) rendered pixels); ``steps_per_frame``;
    ``adapter`` (a notice about the adapter, e.g. the CPU adapter's cheap defaults).
    """
    s = stats
    fps = f"{s['fps']:.1f}" if s.get("fps") is not None else "–"
    target = f" (target {s['target_fps']:g})" if s.get("target_fps") else ""
    parts = [f"{fps} frames/s delivered{target}"]
    if s.get("visible") is not None and s.get("rastered"):
        parts.append(f"{s['visible'] - s['rastered']:,} as ribbons, {s['rastered']:,} in compute")
    if s.get("occluded") is not None:
        parts.append(f"{s['occluded']:,} occluded")
    stages = [(name, s.get(key)) for name, key in (("render", "render_ms"), ("readback", "readback_ms"),
                                                   ("encode", "encode_ms"), ("send", "send_ms"),
                                                   ("ack", "ack_ms"))]
    if any(v is not None for _n, v in stages):
        parts.append(" ".join(f"{n} {v:.{0 if v >= 10 else 1}f}" for n, v in stages if v is not None) + " ms")
    if s.get("unchanged_fps"):
        parts.append(f"{s['unchanged_fps']:.1f} frames/s unchanged (not sent again)")
    elif s.get("draw_ms") is not None:
        parts.append(f"draw {s['draw_ms']:.0f} ms")
    if s.get("gpu_ms"):
        parts.append("GPU " + ", ".join(f"{k} {v:.2f} ms" for k, v in dict(s["gpu_ms"]).items()))
    if s.get("steps_per_frame") is not None:
        parts.append(f"{s['steps_per_frame']} steps/frame")
    size = "{}×{} px".format(*s["frame_size"]) if s.get("frame_size") else ""
    if s.get("scale") is not None:
        parts.append(f"scale {s['scale']:.2f}" + (f" ({size})" if size else ""))
    elif size:
        parts.append(size)
    if s.get("adapter"):
        parts.append(s["adapter"])
    return " · ".join(parts)


def legend_html(color_by: str) -> str:
    """HTML of the legend of a colouring (see :func:`grasswidget.core.teaching.legend`)."""
    rows = legend(color_by)
    if not rows:
        return "<small>natural colours (lit grass)</small>"
    items = []
    for label, color in rows:
        swatch = ("<span style='display:inline-block;width:12px;height:12px;margin-right:4px;"
                  f"vertical-align:middle;background:{color}'></span>") if color else ""
        items.append(f"<span style='margin-right:12px;white-space:nowrap'>{swatch}{html.escape(label)}</span>")
    return "<small>" + "".join(items) + "</small>"


def inspected_html(blades: list) -> str:
    """HTML of the inspected blades' numbers: a list of dicts with ``id``,
    ``height`` (m), ``stiffness`` (1/s^2, with stiffness_scale) and one force
    vector per name of ``reference.FORCE_NAMES`` (m/s^2; collision: the push of
    one step in m). Empty list: a hint."""
    if not blades:
        return "<small>ctrl + click a blade to inspect it</small>"
    lines = []
    for k, b in enumerate(blades[:4]):
        size = {name: float(sum(float(x) * float(x) for x in b[name])) ** 0.5 for name in FORCE_NAMES}
        forces = ", ".join(f"{name} {size[name]:.2f}" for name in FORCE_NAMES if name != "collision")
        text = (f"blade {b['id']}: height {b['height']:.2f} m, stiffness {b['stiffness']:.2f} /s², "
                f"|force| (m/s²): {forces}; collision push {1000 * size['collision']:.1f} mm/step")
        color = INSPECTED_BLADE_COLORS[k % len(INSPECTED_BLADE_COLORS)]  # its colour in the lab bench's charts
        lines.append(f"<span style='color:{color}'>&#9632;</span> " + html.escape(text))
    if len(blades) > 4:
        lines.append(html.escape(f"... and {len(blades) - 4} more"))
    return "<small><code>" + "<br>".join(lines) + "</code></small>"


def _slider(name, owner, step, fmt, width):
    """A FloatSlider for a RangedFloat trait (its range and help text)."""
    trait = owner.traits()[name]
    return ipw.FloatSlider(value=getattr(owner, name), min=trait.lo, max=trait.hi, step=step,
                           description=control_label(name, trait), continuous_update=True, style=_DESC,
                           layout=ipw.Layout(width=width), tooltip=control_tooltip(name, trait), readout_format=fmt)


class ControlPanel:
    """The controls under a GrassWidget's view.

    Args:
        params: the :class:`GrassParams` the sliders, dropdown and checkboxes edit.
        state: a HasTraits with ``time_scale`` and ``culling_frozen`` traits (a GrassWidget's
            :class:`~grasswidget.notebook.widget_state.WidgetState`, or a comparison) for the
            ``time_scale`` slider and the "freeze culling" checkbox.
        actions: the object whose methods the buttons call: ``toggle_play()``,
            ``step()``, ``reset_blades()``, ``reset_camera()``, ``set_blades(n)``, ``target_fps``,
            ``inspect(ids)`` ("Clear": ``inspect([])``) and ``save_png(size=(w, h)) -> path``, or
            ``save_png_later(size, done) -> bool`` (written later, then ``done(path)``).
        blade_count, max_blades: the blade control's count and top (see
            :mod:`grasswidget.notebook.blade_count_control`: powers of two, asks before a
            count slower than the target frame rate).
        view_size: (w, h) CSS pixels of the view (Save PNG multiplies it).
        ball_row: an ipywidget row (the ball's controls) or None.

    Attributes: ``sliders`` (dict name -> slider, incl. "blades" and
    "time_scale"), ``blade_control`` (:class:`BladeCountControl`) and its
    ``blade_slider`` (value: the blade count), ``wind_field_dropdown``, ``checkboxes``
    (dict trait -> checkbox), ``color_by_dropdown``, ``freeze_checkbox``,
    ``legend_line``, ``inspect_line``, ``clear_inspect_button``, ``play_button``, ``step_button``,
    ``reset_blades_button``, ``reset_camera_button``, ``save_button``,
    ``png_scale``, ``file_line``, ``stats_line`` (the one-line status),
    ``details_button`` and ``details_line`` (the timings, shown while the button
    is down), ``look_sliders`` and ``looks_row``, ``message_line``, ``rows``
    (the list of ipywidgets to put under the view).
    """

    def __init__(self, params, state, actions, *, blade_count, max_blades, view_size, ball_row=None):
        self.params = params
        self._actions = actions
        self.view_size = tuple(view_size)
        self._links = []
        err = self.show_error
        column = _column_width(self.view_size[0])

        # blade count: powers of two, asks before a count slower than the target frame rate
        self.blade_control = BladeCountControl(blade_count, max_blades, actions.set_blades, err, width=column,
                                               target_fps=lambda: actions.target_fps,
                                               description=control_label("blades"))
        self.blade_slider = self.blade_control.slider
        self.sliders = {"blades": self.blade_slider}
        for name, step, fmt in PARAM_SLIDERS:
            self.sliders[name] = s = _slider(name, params, step, fmt, column)
            self._links.append(ControlLink(s, params, name, err))
        self.sliders["time_scale"] = ts = _slider("time_scale", state, 0.05, ".2f", column)
        self._links.append(ControlLink(ts, state, "time_scale", err))
        #: The "looks" row's sliders (dict trait -> slider): colour variety, patches, dry grass, sunlit tips, fog,
        #: the sun's height and direction.
        self.look_sliders = {}
        for name, step, fmt in LOOK_SLIDERS:
            if params.has_trait(name):
                self.look_sliders[name] = s = _slider(name, params, step, fmt, column)
                self._links.append(ControlLink(s, params, name, err))

        #: The "looks" row's sunlight switch (GrassParams.shadows), or None for params without it.
        self.shadows_checkbox = None
        if params.has_trait("shadows"):
            self.shadows_checkbox = ipw.Checkbox(value=params.shadows, description=control_label("shadows"),
                                                 indent=False, tooltip=params.traits()["shadows"].help,
                                                 layout=ipw.Layout(width="auto", margin="2px 12px 2px 2px"))
            self._links.append(ControlLink(self.shadows_checkbox, params, "shadows", err))

        choices = tuple(getattr(params.traits()["wind_field"], "choices", None) or WIND_FIELDS)
        wf = params.traits()["wind_field"]
        self.wind_field_dropdown = ipw.Dropdown(options=choices, value=params.wind_field,
                                                description=control_label("wind_field"), style=_DESC,
                                                layout=ipw.Layout(width=column), tooltip=control_tooltip("wind_field", wf))
        self._links.append(ControlLink(self.wind_field_dropdown, params, "wind_field", err))

        self.checkboxes = {}
        for label, name in CULL_CHECKBOXES:
            cb = ipw.Checkbox(value=getattr(params, name), description=label, indent=False,
                              layout=ipw.Layout(width="auto", margin="2px 12px 2px 2px"))
            self._links.append(ControlLink(cb, params, name, err))
            self.checkboxes[name] = cb
        #: The three-way choices (auto / on / off) of the switches decided by measuring, with the decision.
        self.switch_choices = {}
        for label, name in SWITCH_CHOICES:
            self.switch_choices[name] = choice = SwitchChoice(label, params, name, err)
            self._links.append(choice.link)

        # teaching views
        self.color_by_dropdown = ipw.Dropdown(options=COLOR_BY, value=params.color_by, description=control_label("color_by"),
                                              style=_DESC, layout=ipw.Layout(width="240px"),
                                              tooltip=params.traits()["color_by"].help)
        self._links.append(ControlLink(self.color_by_dropdown, params, "color_by", err))
        self.freeze_checkbox = ipw.Checkbox(value=bool(getattr(state, "culling_frozen", False)),
                                            description="freeze culling", indent=False,
                                            layout=ipw.Layout(width="auto", margin="2px 12px 2px 8px"))
        if state.has_trait("culling_frozen"):
            self._links.append(ControlLink(self.freeze_checkbox, state, "culling_frozen", err))
        self.legend_line = ipw.HTML(value=legend_html(params.color_by),
                                    layout=ipw.Layout(min_height="20px", max_width="100%"))
        params.observe(self._on_color_by, names="color_by")
        self.inspect_line = ipw.HTML(value=inspected_html([]), layout=ipw.Layout(min_height="20px", max_width="100%"))
        self.clear_inspect_button = ipw.Button(description="Clear", icon="times", layout=ipw.Layout(width="80px"),
                                               tooltip="Stop inspecting blades")
        self.clear_inspect_button.on_click(lambda _b: self._on_clear_inspect())

        bl = ipw.Layout(width="130px")
        self.play_button = ipw.Button(description="Pause", icon="pause", layout=bl,
                                      tooltip="Play / pause the animation (space)")
        self.step_button = ipw.Button(description="Step", icon="step-forward", layout=bl,
                                      tooltip="Pause and advance one frame (s)")
        self.reset_blades_button = ipw.Button(description="Reset blades", icon="undo", layout=bl,
                                              tooltip="Put every blade back in its rest pose")
        self.reset_camera_button = ipw.Button(description="Reset camera", icon="video-camera", layout=bl,
                                              tooltip="Back to the starting view (r)")
        self.play_button.on_click(lambda _b: actions.toggle_play())
        self.step_button.on_click(lambda _b: actions.step())
        self.reset_blades_button.on_click(lambda _b: actions.reset_blades())
        self.reset_camera_button.on_click(lambda _b: actions.reset_camera())

        self.png_scale = ipw.Dropdown(options=[("1x", 1), ("2x", 2), ("4x", 4)], value=2, description="PNG size",
                                      style={"description_width": "70px"}, layout=ipw.Layout(width="150px"),
                                      tooltip="Resolution of Save PNG, relative to the view")
        self.save_button = ipw.Button(description="Save PNG", icon="camera", layout=bl,
                                      tooltip="Write a PNG into output/ beside the notebook")
        self.save_button.on_click(lambda _b: self._on_save_click())
        self.file_line = ipw.HTML(value="", layout=ipw.Layout(min_height="20px", max_width="100%"))
        self.stats_line = ipw.HTML(value="", layout=ipw.Layout(min_height="20px"))  # the one-line status
        self.details_button = ipw.ToggleButton(value=False, description="details", icon="info",
                                               layout=ipw.Layout(width="90px"),
                                               tooltip="Show the frame's timings, GPU passes and adapter notes")
        self.details_line = ipw.HTML(value="", layout=ipw.Layout(display="none", max_width="100%"))
        self.details_button.observe(self._on_details, names="value")
        self.message_line = ipw.HTML(value="", layout=ipw.Layout(min_height="0px"))

        # Rows that fit the view (two columns of controls in 640 px); each wraps when the view is narrower.
        controls = list(self.sliders.values())
        controls.insert(1, self.blade_control.confirm_row)  # the blade count's question, under it (while asking)
        sliders = _wrapping_row(controls + [self.wind_field_dropdown])
        #: The "looks" row: a heading and the look sliders.
        self.looks_row = _wrapping_row([ipw.HTML("<b>looks</b>", layout=ipw.Layout(width="100%"))]
                                       + list(self.look_sliders.values())
                                       + ([self.shadows_checkbox] if self.shadows_checkbox is not None else []))
        status = _wrapping_row([self.stats_line, self.details_button], justify_content="space-between")
        checkboxes = _wrapping_row(list(self.checkboxes.values()) + [c.box for c in self.switch_choices.values()])
        buttons = _wrapping_row([self.play_button, self.step_button, self.reset_blades_button,
                                 self.reset_camera_button])
        save = _wrapping_row([self.save_button, self.png_scale, self.file_line])
        #: The panel's widgets, top to bottom: stats line first (just under the view).
        teach = ipw.VBox([
            _wrapping_row([self.color_by_dropdown, self.freeze_checkbox, self.legend_line]),
            _wrapping_row([self.clear_inspect_button, self.inspect_line]),
        ], layout=ipw.Layout(width="100%"))
        self.rows = [status, self.details_line, sliders, self.looks_row, checkboxes]
        if ball_row is not None:
            self.rows.append(ball_row)
        self.rows.append(teach)
        self.rows += [buttons, save, self.message_line]

    # ------------------------------------------------------------------ from the widget

    def show_playing(self, playing: bool):
        """The play button says what a click does next."""
        self.play_button.description = "Pause" if playing else "Play"
        self.play_button.icon = "pause" if playing else "play"

    def show_blade_count(self, count: int):
        """Show the blade count (applied elsewhere) on the blade control without asking for a rebuild."""
        self.blade_control.show_count(count)

    def show_stats(self, stats: dict):
        """Show a view's stats dict: the one-line status (:func:`format_status`) and,
        behind the "details" toggle, the timings (:func:`format_details`)."""
        self.blade_control.note_stats(stats)  # the frame rate its estimate scales
        self.stats_line.value = "<small>" + html.escape(format_status(stats)) + "</small>"
        self.details_line.value = "<small><code>" + html.escape(format_details(stats)) + "</code></small>"
        decided = stats.get("switches") or {}
        for name, choice in self.switch_choices.items():
            choice.show(decided.get(name))

    def _on_details(self, change):
        self.details_line.layout.display = "" if change["new"] else "none"

    def show_inspected(self, blades: list):
        """Show the inspected blades' numbers (see :func:`inspected_html`)."""
        self.inspect_line.value = inspected_html(blades)

    def show_unsupported(self, what: str, backend: str):
        """Say that the view in use cannot show ``what`` (instead of failing)."""
        self.message_line.value = (f"<span style='color:#a60'>{html.escape(what)} is not available in the "
                                   f"{html.escape(backend)} engine yet</span>")

    def show_error(self, err):
        """Show an error (an exception or a text) on the message line, in red."""
        self.message_line.value = f"<span style='color:#b00'>{html.escape(str(err))}</span>"

    def show_note(self, text):
        """Show a line of information (not an error) on the message line, e.g. which engine runs and why."""
        self.message_line.value = f"<span style='color:#335'>{html.escape(str(text))}</span>"

    def show_file(self, path, size):
        """Say where a file was written (a link when it is under the working directory)."""
        self.file_line.value = file_link(path, size)

    # ------------------------------------------------------------------ controls

    def _on_color_by(self, change):
        self.legend_line.value = legend_html(change["new"])

    def _on_clear_inspect(self):
        try:
            self._actions.inspect([])
        except Exception as err:
            self.show_error(err)

    def _on_save_click(self):
        w, h = self.view_size  # the widget's size, not the measured view (a border makes that 638 x 478)
        k = int(self.png_scale.value)
        size = (k * w, k * h)
        try:
            # An engine that renders elsewhere (the browser) answers later: the
            # button's handler cannot wait for it, so it says where when written.
            later = getattr(self._actions, "save_png_later", None)
            if later is not None and later(size, lambda path: self.show_file(path, size)):
                return
            path = self._actions.save_png(size=size)
        except Exception as err:
            self.show_error(err)
            return
        self.show_file(path, size)

    def close(self):
        """Unlink every control from its trait and close the panel's widgets."""
        for link in self._links:
            link.unlink()
        self._links = []
        try:
            self.params.unobserve(self._on_color_by, names="color_by")
        except ValueError:
            pass
        todo = list(self.rows)
        while todo:
            w = todo.pop()
            todo.extend(getattr(w, "children", ()))
            close_widgets(w)


def file_link(path, size) -> str:
    """HTML saying where ``path`` ((w, h) pixels) was written."""
    import os

    rel = os.path.relpath(os.path.abspath(path), os.getcwd())
    name = html.escape(os.path.basename(path))
    if rel.startswith(".."):
        return f"saved <code>{html.escape(os.path.abspath(path))}</code> ({size[0]}×{size[1]})"
    return f"saved <a href='{html.escape(rel)}' target='_blank' download>{name}</a> ({size[0]}×{size[1]})"
