"""The GrassWidget's ball: a sphere collider moved with the mouse, sliders, or rolled.

:class:`BallControl` owns one :class:`~grasswidget.SphereCollider` resting on the
ground of a :class:`~grasswidget.gpu.scene.GrassScene` and the controls for it:

* a "sphere" checkbox (``enabled``): the ball is in ``scene.colliders`` (and drawn
  as a translucent ball by the scene) or not;
* ``x``, ``z`` and ``radius`` sliders (metres, in the field's local space);
* **shift + drag** on the view: the ball follows the point of the ground under
  the pointer (a shift-click also switches the ball on; one on the sky switches
  it on where it was, and it follows once the pointer is over the ground);
* a "Roll" toggle (``rolling``): the ball rolls at ``roll_speed`` m/s of
  simulated time along ``path``: by default a circle around the field's centre
  through the ball's position, so it leaves a ring of trampled grass that slowly
  stands back up behind it.

The ball moves with simulated time, never with the wall clock: the widget asks
:meth:`BallControl.step_chunks` how to split a frame's fixed steps so that the
ball moves at most a quarter of its radius between two collision updates.
"""

from __future__ import annotations

import math

import ipywidgets as ipw
import numpy as np
from traitlets import Any, HasTraits

from .. import compat
from ..core.colliders import SphereCollider
from ..core.interaction import ball_reach
from .control_link import ControlLink
from ..errors import GrassValueError, ParameterError
from ..core.params import CheckedBool, RangedFloat

__all__ = ["BallControl", "ground_point"]


def ground_point(camera, x, y, view_size, ground_y=0.0, to_local=None):
    """Where the view ray through pixel (x, y) meets the plane ``Y = ground_y``.

    Args:
        camera: a pygfx camera (its projection and world matrices are used).
        x, y: pointer position in logical pixels, origin top-left.
        view_size: (width, height) of the view in logical pixels.
        ground_y: height of the ground plane in the field's local space (m).
        to_local: 4x4 matrix from world to the field's local space (default identity).

    Returns:
        (X, Z) in metres in the field's local space, or None when the ray does not
        go down to the plane (the pointer is on the sky).
    """
    w, h = float(view_size[0]), float(view_size[1])
    ndc_x, ndc_y = 2.0 * x / w - 1.0, 1.0 - 2.0 * y / h
    proj_inv = np.asarray(camera.projection_matrix_inverse, np.float64)
    cam_world = np.asarray(camera.world.matrix, np.float64)
    to_local = np.eye(4) if to_local is None else np.asarray(to_local, np.float64)
    pts = []
    for depth in (0.0, 1.0):  # WebGPU clip depth runs 0 (near) .. 1 (far)
        p = proj_inv @ np.array([ndc_x, ndc_y, depth, 1.0])
        p = to_local @ (cam_world @ (p / p[3]))
        pts.append(p[:3] / p[3])
    origin, direction = pts[0], pts[1] - pts[0]
    if abs(direction[1]) < 1e-12:
        return None
    s = (ground_y - origin[1]) / direction[1]
    if s <= 0:
        return None
    hit = origin + s * direction
    return float(hit[0]), float(hit[2])


class BallControl(HasTraits):
    """A sphere collider on the ground of a GrassScene, with its controls.

    Args:
        view: what the ball acts on: an object with ``blades`` (a Blades: the ground and the field's
            extent) and ``colliders`` (the live ColliderList), e.g. an
            :class:`~grasswidget.views.api.EngineView` (see :meth:`attach`).
        on_error: called with the exception when a control is given a value the
            collider refuses (the control goes back to the old value).

    Attributes:
        collider: the :class:`SphereCollider` (kept across :meth:`attach`).
        path: None (a circle around the field's centre through the ball) or a
            callable ``path(s) -> (x, z)`` giving the ball's position after rolling
            ``s`` metres.
        controls: the ipywidgets row (checkbox, sliders, Roll button).

    Traits: ``enabled`` (the ball acts on the grass), ``rolling``, ``roll_speed``
    (m/s of simulated time, 0.1..20, default 2).
    """

    enabled = CheckedBool(False, help="The ball is in the scene's colliders (pushes grass, drawn).")
    rolling = CheckedBool(False, help="Roll the ball along its path as simulated time goes by.")
    roll_speed = RangedFloat(2.0, 0.1, 20.0, "m/s", help="Rolling speed, metres per simulated second.")
    path = Any(None, help="None (circle around the field's centre) or a callable s -> (x, z).")

    def __init__(self, view, on_error=None):
        super().__init__()
        self._on_error = on_error or (lambda err: None)
        self._dragging = False
        self._rolled = 0.0  # metres rolled along the current path
        self._circle = None  # (cx, cz, R, angle0) of the current circular path
        self._advancing = False  # the ball moves along its path (not by hand)
        self.view = None
        self._colliders = None  # the ColliderList the ball was last put in (or taken out of)
        self._set_bounds(view)
        radius = round(max(0.1, 0.1 * self._extent), 2)
        self.collider = SphereCollider(center=(self._center[0], self._ground_y + radius, self._center[1]),
                                       radius=radius)
        self.observe(self._on_enabled, names="enabled")
        self.observe(self._on_rolling, names="rolling")
        self.observe(self._on_path, names="path")
        self.collider.observe(self._on_collider, names=["center", "radius"])
        self._build_controls()
        self.attach(view)

    @property
    def roll_center(self) -> tuple:
        """(x, z) of the field's centre in metres: the ball rolls on a circle around it."""
        return tuple(float(c) for c in self._center)

    # ------------------------------------------------------------------ scene

    def _set_bounds(self, view):
        v0 = np.asarray(view.blades.v0, np.float64)
        lo, hi = v0.min(axis=0), v0.max(axis=0)
        self._lo, self._hi = lo, hi
        self._center = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[2] + hi[2]))
        self._extent = float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
        self._ground_y = float(np.median(v0[:, 1]))

    def attach(self, view):
        """Act on ``view`` (after a blade-count change, or another engine's view): the ball keeps
        its place and size; it leaves the colliders it was in and, if enabled, joins ``view.colliders``."""
        old = self._colliders
        if old is not None and old is not view.colliders and self.collider in old:
            old.remove(self.collider)
        self.view = view
        self._colliders = view.colliders
        self._set_bounds(view)
        if hasattr(self, "x_slider"):
            self._update_slider_ranges()
        if self.enabled and self.collider not in view.colliders:
            view.colliders.append(self.collider)

    def join(self, view):
        """:meth:`attach` to ``view`` and let it move the ball with shift + drag and roll it with
        simulated time (the widget's first view, and each after an engine switch)."""
        self.attach(view)
        view.attach_ball(self)

    def detach(self):
        """Take the ball out of the view's colliders and unlink the controls (the widget closes)."""
        self.rolling = False
        if self._colliders is not None and self.collider in self._colliders:
            self._colliders.remove(self.collider)
        self.view = self._colliders = None
        for link in self._links:
            link.unlink()
        self._links = []

    # ------------------------------------------------------------------ controls

    def _build_controls(self):
        # Sized to fit a 640 px view: "sphere", x and z on one line, radius and Roll on the next
        # (the row wraps on a narrower view).
        lay = ipw.Layout(width="272px")
        style = {"description_width": "50px"}
        # continuous_update=False: the page sends a slider's value when the user lets go (or types
        # it), never on its own. With True, ipywidgets' slider sends back the value it snapped to its
        # step grid (1.5 -> 1.4999999999999998) whenever it is drawn or moved from Python: a view
        # drawn late (Run All) sent a stale radius over a later ``set_radius``, and echoes of the
        # rolling ball's position read as moves by hand.
        self.checkbox = ipw.Checkbox(value=False, description="sphere", indent=False,
                                     layout=ipw.Layout(width="76px"),
                                     tooltip="A sphere collider on the ground (shift + drag on the view moves it)")
        self.x_slider = ipw.FloatSlider(description="x", step=0.05, readout_format=".2f", style=style, layout=lay,
                                        continuous_update=False, tooltip="Ball centre x (m)")
        self.z_slider = ipw.FloatSlider(description="z", step=0.05, readout_format=".2f", style=style, layout=lay,
                                        continuous_update=False, tooltip="Ball centre z (m)")
        self.radius_slider = ipw.FloatSlider(description="radius", step=0.05, readout_format=".2f", style=style,
                                             layout=lay, continuous_update=False, tooltip="Ball radius (m)")
        self._update_slider_ranges()
        self.roll_button = ipw.ToggleButton(value=False, description="Roll", icon="circle",
                                            layout=ipw.Layout(width="90px"),
                                            tooltip="Roll the ball along its path (a circle around the field's centre)")
        err, col = self._on_error, self.collider
        self._links = [
            ControlLink(self.checkbox, self, "enabled", err),
            ControlLink(self.roll_button, self, "rolling", err),
            ControlLink(self.x_slider, col, "center", err, to_obj=lambda x: self._on_ground(x=x),
                        to_control=lambda c: c[0]),
            ControlLink(self.z_slider, col, "center", err, to_obj=lambda z: self._on_ground(z=z),
                        to_control=lambda c: c[2]),
            ControlLink(self.radius_slider, col, "radius", err),
        ]
        self.controls = ipw.HBox([self.checkbox, self.x_slider, self.z_slider, self.radius_slider, self.roll_button],
                                 layout=ipw.Layout(width="100%", flex_flow="row wrap", align_items="center"))

    def _update_slider_ranges(self):
        """Slider ranges for the current field (a ball outside is brought to the edge)."""
        x0, x1, z0, z1 = ball_reach(self._lo, self._hi)  # the field and a margin (the live page's too)
        rmax = round(max(0.5, 0.3 * self._extent), 2)
        ranges = ((self.x_slider, x0, x1), (self.z_slider, z0, z1),
                  (self.radius_slider, 0.05, rmax))
        for slider, lo, hi in ranges:
            if lo > slider.max:  # keep min <= max at every moment
                slider.max, slider.min = hi, lo
            else:
                slider.min, slider.max = lo, hi

    # ------------------------------------------------------------------ moving

    def _on_ground(self, x=None, z=None):
        """The centre (x, ground + radius, z), metres; None keeps that coordinate."""
        cx, _cy, cz = self.collider.center
        x = cx if x is None else x
        z = cz if z is None else z
        for name, v in (("x", x), ("z", z)):
            if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) or not math.isfinite(float(v)):
                raise GrassValueError(f"ball {name} must be a finite number (metres); got {v!r}")
        return (float(x), self._ground_y + self.collider.radius, float(z))

    def move_to(self, x=None, z=None):
        """Put the ball at (x, z) on the ground (metres; None keeps that coordinate)."""
        self.collider.center = self._on_ground(x, z)

    def set_radius(self, radius):
        """Resize the ball (metres, > 0); it stays resting on the ground."""
        self.collider.radius = radius

    def _on_collider(self, change):
        if change["name"] == "radius":
            self.collider.center = self._on_ground()  # resting on the ground
        elif not self._advancing:
            self._circle = None  # moved by hand: a new path from here

    def _on_enabled(self, change):
        colliders = self._colliders
        if colliders is not None:
            if change["new"] and self.collider not in colliders:
                colliders.append(self.collider)
            elif not change["new"] and self.collider in colliders:
                colliders.remove(self.collider)
        if not change["new"]:
            self.rolling = False

    def _on_rolling(self, change):
        if change["new"]:
            self.enabled = True
        self.roll_button.description = "Stop" if change["new"] else "Roll"

    def _on_path(self, change):
        if change["new"] is not None and not callable(change["new"]):
            self.path = change["old"]
            raise ParameterError(f"path must be None or a callable s -> (x, z); got {change['new']!r}")
        self._rolled, self._circle = 0.0, None

    def _start_circle(self):
        """A circle around the field's centre through the ball (radius clamped to
        0.15..0.45 of the field's size); the ball is at its start now."""
        cx, cz = self._center
        bx, _by, bz = self.collider.center
        r = math.hypot(bx - cx, bz - cz)
        a0 = math.atan2(bz - cz, bx - cx) if r > 1e-9 else 0.0
        radius = min(max(r, 0.15 * self._extent), 0.45 * self._extent)
        self._circle = (cx, cz, radius, a0 - self._rolled / radius)

    def _position_after(self, s):
        """Ball (x, z) after rolling s metres along the path."""
        if self.path is not None:
            x, z = self.path(s)
            return float(x), float(z)
        cx, cz, r, a0 = self._circle
        a = a0 + s / r
        return cx + r * math.cos(a), cz + r * math.sin(a)

    def advance(self, seconds):
        """Roll the ball for ``seconds`` of simulated time (no-op unless rolling)."""
        if not (self.rolling and self.enabled) or seconds <= 0:
            return
        if self.path is None and self._circle is None:
            self._start_circle()
        self._rolled += self.roll_speed * seconds
        x, z = self._position_after(self._rolled)
        self._advancing = True
        try:
            self.move_to(x, z)
        finally:
            self._advancing = False

    def step_chunks(self, n, dt):
        """Split ``n`` fixed steps of ``dt`` seconds so that a rolling ball moves at
        most a quarter of its radius per chunk; returns a list of step counts."""
        if n <= 0:
            return []
        if not (self.rolling and self.enabled):
            return [n]
        per = max(1, int(0.25 * self.collider.radius / (self.roll_speed * dt)))
        return [per] * (n // per) + ([n % per] if n % per else [])

    # ------------------------------------------------------------------ pointer

    def handle_event(self, event, view_size, scene):
        """Shift + left-drag moves the ball over the ground of ``scene`` (the kernel engine's
        GrassScene: its camera and the field's placement turn the pointer into a ground point).
        Returns True when the event was used (then it must not reach the camera controller)."""
        kind = compat.event_type(event)
        if kind == "pointer_down":
            if event.get("button") == 1 and "Shift" in tuple(event.get("modifiers") or ()):
                self._dragging = True
                self.rolling = False
                self._drag_to(event, view_size, scene, switch_on=True)
                return True
            return False
        if kind == "pointer_move" and self._dragging:
            self._drag_to(event, view_size, scene)
            return True
        if kind == "pointer_up" and self._dragging:
            self._dragging = False
            self._drag_to(event, view_size, scene)
            return True
        return False

    def _drag_to(self, event, view_size, scene, switch_on=False):
        hit = ground_point(scene.camera, float(event.get("x", 0.0)), float(event.get("y", 0.0)), view_size,
                           self._ground_y, np.asarray(scene.field.world.inverse_matrix))
        if hit is None:  # on the sky: the ball stays where it is (a press there still switches it on)
            if switch_on:
                self.enabled = True
            return
        x0, x1, z0, z1 = ball_reach(self._lo, self._hi)
        x = min(max(hit[0], x0), x1)
        z = min(max(hit[1], z0), z1)
        self.move_to(x, z)
        if switch_on:
            self.enabled = True
