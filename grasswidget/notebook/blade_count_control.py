"""The panel's blade count control: powers of two, in words, and a question before a slow count.

A linear slider from 1 to the adapter's maximum (4,194,304 on a GPU) moves tens of
thousands of blades per pixel: a small nudge froze a live lecture demo. This control
moves in powers of two instead (one arrow key press or one step of the slider doubles
or halves the count), and its readout writes the count out, ``"65,536"``.

**When it asks first.** A count the meadow will not draw at the view's ``target_fps``
is not applied at once: a line under the slider says ``"Apply 262,144 blades? about
3.1 frames/s here (target 24)"`` with Apply and Cancel. The estimate
(:func:`estimate_fps`) scales the frame time measured now (frames/s delivered while
playing, from the view's stats) by the blade count: ``fps(n) = fps_now * blades_now
/ n``. A frame costs a fixed part plus a part per blade, ``T(n) = a + b n``; for
``n >= blades_now`` the estimate ``T(blades_now) * n / blades_now`` is at least
``T(n)``, so it never understates the cost (it errs towards asking). Fewer blades
never ask. Before any frame rate was measured (a fresh or never-played view) a
larger count asks too, saying the frame rate is not measured yet. The top of the
control is the adapter's maximum (``max_blades``: the engine's comfortable maximum
within what :mod:`grasswidget.core.memory` says host memory and the GPU's buffers
hold), checked by the widget before anything is allocated.

``w.blade_count = n`` and ``w.set_blades(n)`` take any count in range from code; the
control then shows that exact count (added to its stops) without asking.
"""

from __future__ import annotations

import html

import ipywidgets as ipw

from .layout import close_widgets

__all__ = ["BladeCountControl", "blade_stops", "count_words", "estimate_fps", "needs_confirmation"]

def count_words(n: int) -> str:
    """A blade count as the control's readout writes it, with thousands separators:
    ``"262,144"`` (the readout is 72 CSS px wide; a power of two written after it,
    "262,144 (2¹⁸)", would be clipped)."""
    return f"{int(n):,}"


def blade_stops(max_blades: int, current: int | None = None) -> list:
    """The counts the control offers, ascending: every power of two from 1 to
    ``max_blades`` (1..max), ``max_blades`` itself when it is not a power of two, and
    ``current`` (a count set from code) when it is in range and not among them."""
    max_blades = int(max_blades)
    stops = {1 << k for k in range(max_blades.bit_length()) if 1 << k <= max_blades}
    stops.add(max_blades)
    if current is not None and 1 <= int(current) <= max_blades:
        stops.add(int(current))
    return sorted(stops)


def estimate_fps(count: int, measured_fps, measured_blades) -> float | None:
    """Frames/s expected with ``count`` blades, from ``measured_fps`` frames/s measured
    with ``measured_blades`` blades: the frame time scaled by the blade count,
    ``measured_fps * measured_blades / count`` (an upper bound of the cost for
    ``count >= measured_blades``, see the module docstring). None when nothing was
    measured (``measured_fps`` None or <= 0)."""
    if not measured_fps or measured_fps <= 0 or not measured_blades:
        return None
    return float(measured_fps) * float(measured_blades) / float(count)


def needs_confirmation(count: int, current: int, measured_fps, measured_blades, target_fps) -> bool:
    """True when going from ``current`` to ``count`` blades should ask first: more
    blades than now, and either no frame rate measured yet or the estimate
    (:func:`estimate_fps`) below ``target_fps`` frames/s."""
    if count <= current:
        return False
    fps = estimate_fps(count, measured_fps, measured_blades)
    return fps is None or target_fps is None or fps < float(target_fps)


class BladeCountControl:
    """The blade count slider (powers of two), its confirmation line and its buttons.

    Args:
        count: the blade count shown at first.
        max_blades: the top of the control (the adapter's maximum, see the module docstring).
        apply: called with a blade count to apply it (the widget's ``set_blades``);
            an exception it raises goes to ``on_error`` and the control goes back.
        on_error: shows an error (the panel's message line).
        width: CSS width of the slider; description: its label.
        target_fps: a function returning the frames/s to keep (the widget's
            ``target_fps``, read at each choice), or None: the stats' ``target_fps``.

    Attributes: ``slider`` (an ipywidgets ``SelectionSlider`` whose ``value`` is the
    blade count, applied on release or key press), ``question`` (the confirmation
    text), ``apply_button``, ``cancel_button``, ``confirm_row`` (hidden unless a
    count waits), ``pending`` (the count waiting for Apply, or None), ``count``
    (the count applied), ``measured`` ((frames/s, blades) of the last measurement
    while playing, or None) and :attr:`target_fps`.
    """

    def __init__(self, count, max_blades, apply, on_error, width="314px", target_fps=None, description="blades"):
        self.max_blades = int(max_blades)
        self.count = int(count)
        self.pending = None
        self.measured = None
        self._target_source = target_fps
        self._stats_target = None
        self._apply = apply
        self._on_error = on_error
        self.slider = ipw.SelectionSlider(
            options=self._options(self.count), value=self.count, description=description,
            continuous_update=False, style={"description_width": "140px"}, layout=ipw.Layout(width=width),
            tooltip=("Number of blades, in powers of two (arrow keys: double / halve). Rebuilds the field; "
                     "a count slower than the target frame rate asks first."),
        )
        self.slider.observe(self._on_slider, names="value")
        self.question = ipw.HTML(value="", layout=ipw.Layout(max_width="100%"))
        bl = ipw.Layout(width="80px")
        self.apply_button = ipw.Button(description="Apply", button_style="warning", layout=bl,
                                       tooltip="Build the field with this many blades")
        self.cancel_button = ipw.Button(description="Cancel", layout=bl, tooltip="Keep the blades as they are")
        self.apply_button.on_click(lambda _b: self.confirm())
        self.cancel_button.on_click(lambda _b: self.cancel())
        self.confirm_row = ipw.HBox([self.question, self.apply_button, self.cancel_button],
                                    layout=ipw.Layout(width="100%", flex_flow="row wrap", align_items="center",
                                                      display="none"))

    @property
    def target_fps(self) -> float | None:
        """Frames/s a count must keep to be applied without asking (the widget's
        ``target_fps``; None when unknown)."""
        if self._target_source is not None:
            try:
                return float(self._target_source())
            except Exception:  # noqa: BLE001  (a closed widget: fall back on the stats)
                pass
        return self._stats_target

    def _options(self, current):
        return [(count_words(n), n) for n in blade_stops(self.max_blades, current)]

    # ------------------------------------------------------------------ from the widget

    def show_count(self, count: int):
        """Show ``count`` (applied elsewhere, e.g. from code) without applying anything;
        a waiting question goes away."""
        self.count = int(count)
        self._hide_question()
        self._move_slider(self.count)

    def note_stats(self, stats: dict):
        """Remember the frame rate measured while playing (``fps`` with ``blades``; not of a
        window where ``trial`` says the "auto" switches ran a trial) and the view's
        ``target_fps``, for the estimate."""
        if stats.get("target_fps"):
            self._stats_target = float(stats["target_fps"])
        fps, blades = stats.get("fps"), stats.get("blades")
        # A window in which the "auto" switches ran a trial (``trial``: its frames GPU-synchronised,
        # the first after a flip compiling) is not the view's frame rate: not kept.
        if stats.get("playing") is not False and not stats.get("trial") and fps and fps > 0 and blades:
            self.measured = (float(fps), int(blades))

    # ------------------------------------------------------------------ the control

    def choose(self, count: int):
        """What the slider does with a new count: apply it, or ask first (see
        :func:`needs_confirmation`)."""
        count = int(count)
        if count == self.count:
            self._hide_question()
            return
        fps, blades = self.measured or (None, None)
        if needs_confirmation(count, self.count, fps, blades, self.target_fps):
            self._ask(count, estimate_fps(count, fps, blades))
        else:
            self._hide_question()
            self._do_apply(count)

    def confirm(self):
        """Apply the count waiting for confirmation (the Apply button)."""
        count, self.pending = self.pending, None
        self._hide_question()
        if count is not None:
            self._do_apply(count)

    def cancel(self):
        """Drop the waiting count; the slider goes back to the applied one (Cancel)."""
        self._hide_question()
        self._move_slider(self.count)

    def _do_apply(self, count):
        try:
            self._apply(count)
        except Exception as err:  # e.g. out of GPU memory: the old field stays
            self._on_error(err)
            self._move_slider(self.count)
            return
        self.count = count
        self._move_slider(count)

    def _ask(self, count, fps):
        self.pending = count
        target_fps = self.target_fps
        target = f" (target {target_fps:g})" if target_fps else ""
        cost = (f"about {fps:.2g} frames/s here{target}" if fps is not None
                else "the frame rate is not measured yet (play the view first)")
        self.question.value = (f"<span style='color:#a60'>Apply {count:,} blades? "
                               f"{html.escape(cost)}</span>")
        self.apply_button.description = "Apply"
        self.confirm_row.layout.display = ""

    def _hide_question(self):
        self.pending = None
        self.question.value = ""
        self.confirm_row.layout.display = "none"

    def _on_slider(self, change):
        self.choose(change["new"])

    def _move_slider(self, count):
        """Put the slider on ``count`` (a stop of its own when set from code), without choosing."""
        self.slider.unobserve(self._on_slider, names="value")
        try:
            options = self._options(count)
            if [v for _l, v in self.slider.options] != [v for _l, v in options]:
                self.slider.options = options
            self.slider.value = count
        finally:
            self.slider.observe(self._on_slider, names="value")

    def close(self):
        close_widgets(self.slider, self.question, self.apply_button, self.cancel_button, self.confirm_row)
