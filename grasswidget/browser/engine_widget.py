"""BrowserEngineWidget: the grass simulated, culled and drawn in the notebook's browser (WebGPU).

An anywidget whose ES module (``engine.js`` and its modules under ``js/``, shipped in the
package and assembled into one module text by :func:`grasswidget.browser.esm.engine_module_text`) asks the
browser for a WebGPU adapter, receives the rest pose of the blades as one binary
buffer and the parameters as packed uniforms (synced traits), compiles the
project's own WGSL (rendered for its bindings by :mod:`grasswidget.browser.browser_wgsl`)
and runs the simulation, culling, LOD binning and the ribbon draws every frame.
The kernel needs no GPU for it.

It knows nothing of panels: :class:`grasswidget.GrassWidget` composes it with the
control panel. Alone it is usable too::

    from grasswidget.browser import BrowserEngineWidget
    v = BrowserEngineWidget(Blades.on_plane(4096))
    v                              # show it
    v.step(120); v.read_state()    # exact fixed steps; the state read back from the browser

Teaching views, as in the kernel engine: :meth:`BrowserEngineWidget.freeze_culling`
(the frozen camera's values go to the browser in ``u_cull``, its view volume as
line data computed here), :meth:`BrowserEngineWidget.inspect` (the browser runs the
project's ``inspect.wgsl`` and draws its lines and points) and
:meth:`BrowserEngineWidget.read_inspected` (the numbers GrassScene.read_inspected gives).

Requests that need the browser's answer (:meth:`read_state`, :meth:`snapshot`,
:meth:`read_inspected`, :meth:`set_wind_wgsl`) wait for it while still processing the notebook's widget
messages (``jupyter-ui-poll``), so they work inside a running cell; with no view
answering they raise ``TimeoutError`` naming the browser view.

The "auto" switches (``params.cull_occlusion``, ``params.compute_raster``) are decided here, by
measuring the browser's frames (:mod:`grasswidget.browser.trial_feed`, the kernel's rule): each
stats message carries ``frame_times`` (ms), ``timed_switches`` and ``counts_switches``
(``[occlusion, compute raster]`` as the browser executed them; js/messages.js documents the
message), and Python answers with the state to execute as ``u_cull``'s ``occlusion_phase`` and
``compute_raster`` words. ``auto_switches.texts()`` says what was decided.
"""

from __future__ import annotations

import itertools
import uuid
from pathlib import Path

import anywidget
import numpy as np
from traitlets import Bool, Bytes, Dict, Float, Int, List, Unicode

from ..errors import GrassTypeError, GrassValueError
from ..core.blades import Blades, unpack_state
from ..core.colliders import ColliderList, collider_array
from ..core.limits import check_steps, nonfinite_cause, nonfinite_message, warn_nonfinite
from ..core import camera_rules
from ..core.engine_inputs import SKY_GROUND_TRAITS, STATS_INTERVAL_MS, export_filter, frame_rules, scene_style
from ..core.orbit_limits import OrbitLimits, check_floor
from ..core.params import SUN_TRAITS, GrassParams
from ..core.reference import FORCE_NAMES
from ..core.teaching import FrozenView, check_inspect_ids, frozen_view, inspected_rows
from ..core.uniform_layouts import INSPECT_LAYOUT, pack
from ..core.wgsl_overrides import wind_limit_error
from . import uniforms
from .trial_feed import BrowserAutoSwitches
from .esm import engine_module_text
from .kernel_pump import BrowserTimeoutError, wait_for
from .browser_wgsl import USER_WIND_SIGNATURE, BrowserShaders, wind_body, with_function_overrides

__all__ = ["BrowserEngineWidget", "BrowserTimeoutError", "wind_error_from_messages"]

HERE = Path(__file__).resolve().parent
#: Seconds a request waits for the browser's answer by default.
ANSWER_TIMEOUT = 30.0

def wind_error_from_messages(messages, wgsl, body, reason=""):
    """A :class:`~grasswidget.gpu.field.WindShaderError`-like ValueError from the
    browser compiler's messages ([{line, column, message}], lines of the whole
    simulation shader), with the line inside the user's snippet."""
    from ..errors import WindShaderError

    lines = wgsl.splitlines()
    start = next((k + 2 for k, line in enumerate(lines) if line.strip() == USER_WIND_SIGNATURE), None)
    n_body = max(len(body.splitlines()), 1)
    for m in messages:
        line = m.get("line")
        if start is not None and line is not None and start <= line < start + n_body:
            snippet_line = line - start + 1
            src = body.splitlines()[snippet_line - 1] if snippet_line <= len(body.splitlines()) else ""
            col = m.get("column")
            message = (f"wind_wgsl line {snippet_line}, column {col}: {m.get('message', '')} "
                       f"(compiled in the browser)\n  {snippet_line} | {src}")
            return WindShaderError(message, snippet_line, col, m.get("message", ""), reason)
    text = "; ".join(m.get("message", "") for m in messages) or reason
    return WindShaderError(
        f"wind_wgsl does not compile as the body of `{USER_WIND_SIGNATURE} ... }}` (in the browser): {text}",
        None, None, text, reason,
    )


class BrowserEngineWidget(anywidget.AnyWidget):
    """The browser engine's view (see the module docstring).

    Args:
        blades: a :class:`Blades` (rest pose) or a blade count (``Blades.on_plane``).
        params: a :class:`GrassParams` (shared; default a new one).
        size: (width, height) of the view in CSS pixels.
        camera: dict with position, target (metres), fov_deg (vertical), near, far.

    Traits read by Python: ``gpu_status`` ({"state": "" | "ok" | "unavailable",
    "detail"}), ``camera`` (both ways), ``playing``, ``time_scale``.
    """

    # The module's text, not its path: anywidget 0.11 connects every instance of a
    # widget whose _esm is a file path to that file's class-wide change signal with a
    # strong closure, which keeps every BrowserEngineWidget (and its GrassWidget) alive forever.
    _esm = engine_module_text()

    # ---- state sent to the browser
    #: One engine per widget in the page, however many times it is displayed (engine.js keys it by this).
    engine_key = Unicode("").tag(sync=True)
    blade_data = Bytes(b"").tag(sync=True)
    n_blades = Int(0).tag(sync=True)
    shaders = Dict().tag(sync=True)
    sim_uniform = Bytes(b"").tag(sync=True)
    sim_layout = Dict().tag(sync=True)
    cull_uniform = Bytes(b"").tag(sync=True)
    material_uniform = Bytes(b"").tag(sync=True)
    sky_ground_uniform = Bytes(b"").tag(sync=True)
    ball_uniform = Bytes(b"").tag(sync=True)
    stdinfo_size = Int(0).tag(sync=True)
    stdinfo_layout = Dict().tag(sync=True)
    #: grasswidget.core.engine_inputs.frame_rules: the clock's rules, the orbit limits, the scene style.
    frame_rules = Dict().tag(sync=True)
    playing = Bool(True).tag(sync=True)
    time_scale = Float(1.0).tag(sync=True)
    camera = Dict().tag(sync=True)
    #: What the orbit keeps the camera above (Python side; it reaches the browser as the numbers of
    #: ``frame_rules["orbit"]``): "grass" (the tallest tip) or "ground" (core.orbit_limits.FLOORS).
    camera_floor = Unicode("grass")
    #: The colliders as [[x, y, z, r], ...] (Python side; the browser gets the two arrays below).
    balls = List()
    #: The spheres (K x 4 float32) and their grid (u32 words; grasswidget.core.collider_grid).
    collider_spheres = Bytes(b"").tag(sync=True)
    collider_grid = Bytes(b"").tag(sync=True)
    #: Bytes of the browser's two collider buffers (their fixed sizes).
    collider_buffer_bytes = List([uniforms.COLLIDER_BYTES, uniforms.GRID_BYTES]).tag(sync=True)
    show_colliders = Bool(True).tag(sync=True)
    #: The browser sends a "steps" message about every 60 ms (the rolling ball follows simulated time).
    report_steps = Bool(False).tag(sync=True)
    #: Milliseconds between the browser's stats messages (100..2000, default engine_inputs.STATS_INTERVAL_MS;
    #: the lab bench's traces sample at each).
    stats_interval_ms = Int(STATS_INTERVAL_MS).tag(sync=True)
    #: Rendered pixels per CSS pixel; 0 = the display's devicePixelRatio (at most 2).
    pixel_ratio = Float(0.0).tag(sync=True)
    width = Int(640).tag(sync=True)
    height = Int(480).tag(sync=True)
    #: The frozen culling camera's view volume: 12 edges, 24 x 3 float32 (world space); empty: not frozen.
    frustum_lines = Bytes(b"").tag(sync=True)
    #: ``u_inspect`` packed (core.uniform_layouts.INSPECT_LAYOUT) and the inspected blade ids.
    inspect_uniform = Bytes(b"").tag(sync=True)
    inspected = List().tag(sync=True)
    # ---- set by the browser
    gpu_status = Dict({"state": "", "detail": ""}).tag(sync=True)

    def __init__(self, blades=4096, params: GrassParams | None = None, size=(640, 480), camera=None,
                 function_overrides=None, **kwargs):
        if isinstance(blades, (int, np.integer)) and not isinstance(blades, bool):
            blades = Blades.on_plane(int(blades))
        if not isinstance(blades, Blades):
            raise GrassTypeError(f"blades must be a Blades or a blade count, not {type(blades).__name__}")
        if params is not None and not isinstance(params, GrassParams):
            raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
        self.params = params if params is not None else GrassParams()
        #: User WGSL replacing blade-math functions (a FunctionOverrides, e.g. an exercise's), compiled
        #: by the browser with every shader when the engine starts; None: the stock functions.
        self.function_overrides = function_overrides
        self._colliders = ColliderList()
        self._answers = {}
        self._ids = itertools.count(1)
        self._listeners = {"stats": [], "ball": [], "key": [], "error": [], "device_lost": [], "steps": [],
                           "pick": [], "rest": []}
        self._frozen = None
        self._wind_body = self.params.wind_wgsl
        self._reverting_wind = False
        self._warned_cause = None  # the cause of the last NonFiniteStateWarning (note_reset_flag)
        self.step_count_hint = 0
        self.last_stats = {}
        #: The last 20 errors the browser reported (text), newest last.
        self.errors = []
        super().__init__(width=int(size[0]), height=int(size[1]), engine_key=uuid.uuid4().hex, **kwargs)
        with self.hold_sync():
            self.stdinfo_size = uniforms.struct_size(uniforms.STDINFO_LAYOUT)
            self.stdinfo_layout = uniforms.layout_description(uniforms.STDINFO_LAYOUT)
            self.sim_layout = uniforms.layout_description(uniforms.SIM_LAYOUT)
            self.shaders = self._shader_tree()
            self.inspect_uniform = pack(INSPECT_LAYOUT, {"n_ids": 0})
            self._set_blades(blades)
            self.camera = dict(camera) if camera else camera_rules.default_camera(blades.v0)
            self._write_frame_rules()
        self.home_camera = dict(self.camera)
        self.observe(self._on_camera_far, names="camera")
        self.observe(self._on_camera_floor, names="camera_floor")
        self.params.observe(self._on_params)
        #: The "auto" switches, decided by measuring the browser's frames (grasswidget.browser.trial_feed).
        self.auto_switches = BrowserAutoSwitches(self, self._write_switches)
        self.auto_switches.refresh()
        self.observe(lambda _change: self.auto_switches.refresh(), names="camera")  # moved far: decide again
        self.on_msg(self._on_browser_msg)

    # ------------------------------------------------------------------ data

    def _shader_tree(self) -> dict:
        """Every shader for the wind compiled last, the sunlight's switch (``params.shadows``:
        the draws compile its maths in only while it is on) and the blades' camera-following levels
        (a field to the horizon, ``Blades.horizon``: compiled in only for such a field), with the
        function overrides."""
        self._shaders_follow = self._follows_camera()
        tree = BrowserShaders.all(self._wind_body, sunlight=bool(self.params.shadows),
                                  follow_camera=self._shaders_follow)
        return with_function_overrides(tree, self.function_overrides)

    def _follows_camera(self) -> bool:
        """Whether the field is one to the horizon whose blades follow the camera (``Blades.horizon``)."""
        return getattr(getattr(self, "blades", None), "horizon", None) is not None

    def _set_blades(self, blades: Blades):
        self.blades = blades
        with self.hold_sync():
            if self._follows_camera() != getattr(self, "_shaders_follow", None):
                self.shaders = self._shader_tree()  # the level code in (or out of) the culling and the draws
            kept = [i for i in self.inspected if i < len(blades)]
            if kept != list(self.inspected):
                self._set_inspected(kept)
            self.n_blades = len(blades)
            self._write_uniforms()
            if self.camera:
                self._write_frame_rules()
            self.blade_data = np.ascontiguousarray(blades.packed(), np.float32).tobytes()

    def set_blades(self, blades: Blades):
        """Replace the field (the camera is kept); the browser restarts from this rest pose."""
        self._set_blades(blades)
        self.auto_switches.field_changed()
        self.auto_switches.refresh()

    def _write_frame_rules(self):
        """The clock's rules, orbit limits and scene style for these blades, params and camera far plane."""
        rules = frame_rules(self.params, self.blades, self.camera.get("far"), check_floor(self.camera_floor))
        self.frame_rules = rules
        self._write_sky_ground()
        self.ball_uniform = uniforms.ball_uniform(rules["style"])

    def _write_sky_ground(self):
        """The sky and ground's uniform: the frame rules' style with the balls' shadows (the colliders
        change often, the frame rules seldom)."""
        style = scene_style(self.blades, self.camera.get("far"), self.params, self._colliders)
        self.sky_ground_uniform = uniforms.sky_ground_uniform(style)

    @property
    def orbit_limits(self) -> OrbitLimits:
        """The orbit limits the browser holds its drags to (what ``frame_rules["orbit"]`` says)."""
        rules = dict(self.frame_rules["orbit"])
        return OrbitLimits(**{k: tuple(v) if isinstance(v, list) else v for k, v in rules.items()})

    def _on_camera_floor(self, change):
        with self.hold_sync():
            self._write_frame_rules()

    def _on_camera_far(self, change):
        if (change["old"] or {}).get("far") != (change["new"] or {}).get("far"):
            with self.hold_sync():
                self._write_frame_rules()

    def _write_uniforms(self):
        p, n = self.params, len(self.blades)
        self.sim_uniform = uniforms.sim_uniform(p, n, self._colliders)
        self.cull_uniform = self._cull_uniform()
        self.material_uniform = uniforms.material_uniform(p, self.blades, self._colliders)
        if self.camera:
            self.frame_rules = dict(self.frame_rules, clock=uniforms.clock(p))
        self._write_colliders()

    def _cull_uniform(self) -> bytes:
        """``u_cull`` for the params, the frozen view and the "auto" switches' current values."""
        switches = getattr(self, "auto_switches", None)
        return uniforms.cull_uniform(self.params, len(self.blades), self._frozen, switches.values if switches else None,
                                     horizon=self.blades.horizon)

    def _write_switches(self, _values):
        """The "auto" switches' values changed: the browser executes them from ``u_cull``."""
        self.cull_uniform = self._cull_uniform()

    def _write_colliders(self):
        self.balls = [list(map(float, row)) for row in collider_array(self._colliders)]
        self.collider_spheres, self.collider_grid = uniforms.collider_buffers(self._colliders, self.blades)

    @property
    def colliders(self) -> ColliderList:
        """Sphere colliders (like GrassField.colliders); call :meth:`colliders_changed` after moving one."""
        return self._colliders

    @colliders.setter
    def colliders(self, value):
        self._colliders = value if isinstance(value, ColliderList) else ColliderList(value)
        self.colliders_changed()

    def colliders_changed(self):
        """Send the colliders' current positions and radii to the browser."""
        with self.hold_sync():
            self.sim_uniform = uniforms.sim_uniform(self.params, len(self.blades), self._colliders)
            self._write_colliders()
            # the balls' shadows (shadows.wgsl reads them from both materials)
            self.material_uniform = uniforms.material_uniform(self.params, self.blades, self._colliders)
            if self.camera:
                self._write_sky_ground()

    def _on_params(self, change):
        if change["name"] == "wind_wgsl":
            if not self._reverting_wind:
                self._request_wind(change["new"], change["old"], wait=False)
                self._warned_cause = None  # a new snippet that fails is worth its own warning
            return
        self.auto_switches.params_changed(change["name"])
        with self.hold_sync():
            self.auto_switches.refresh()
            self._write_uniforms()
            if change["name"] == "shadows":  # the draws with or without the sunlight's maths
                self.shaders = self._shader_tree()
            if change["name"] in (*SKY_GROUND_TRAITS, *SUN_TRAITS) and self.camera:  # the sky/ground: fog, sun, far grass
                self._write_frame_rules()

    # ------------------------------------------------------------------ commands

    def step(self, n: int = 1):
        """Advance exactly ``n`` fixed steps of ``params.dt`` in the browser (in order with other requests);
        ``n`` an integer in [0, MAX_STEPS] (:mod:`grasswidget.core.limits`)."""
        n = check_steps(n)
        if n:
            self.send({"type": "step", "n": int(n)})

    def reset(self):
        """Every blade back to its rest pose, collision strengths, the reset flag and the step counter to 0."""
        self._warned_cause = None
        self.send({"type": "reset"})

    def reset_camera(self):
        self.camera = dict(self.home_camera)

    def lose_device(self):
        """Make the browser destroy its WebGPU device, as a driver reset would (for tests)."""
        self.send({"type": "lose_device"})

    # ------------------------------------------------------------------ teaching views

    def viewport_size(self) -> tuple:
        """(w, h) physical pixels of the view as the browser last drew it (its stats),
        else the CSS size times ``pixel_ratio`` (1 when it is the display's)."""
        size = (self.last_stats or {}).get("frame_size")
        if size and size[0] > 0 and size[1] > 0:
            return (int(size[0]), int(size[1]))
        ratio = self.pixel_ratio if self.pixel_ratio > 0 else 1.0
        return (max(1, round(self.width * ratio)), max(1, round(self.height * ratio)))

    def freeze_culling(self, viewport_size=None, frozen: FrozenView | None = None):
        """Cull and pick LOD classes against a copy of the current camera from now on
        (as ``GrassScene.freeze_culling``): the browser culls with the copy's values
        (``u_cull``) whatever the camera does, and draws its view volume as white lines.

        Args:
            viewport_size: (w, h) physical pixels the copy is taken at (its aspect and the
                LOD classes' pixel scale); default :meth:`viewport_size`.
            frozen: a :class:`~grasswidget.core.teaching.FrozenView` to use instead of the camera
                (e.g. a kernel field's ``frozen_camera``).
        Freezing again takes a new copy. Returns the frozen view."""
        if frozen is None:
            frozen = frozen_view(self.camera, viewport_size or self.viewport_size())
        elif not isinstance(frozen, FrozenView):
            raise GrassTypeError(f"frozen must be a FrozenView or None, not {type(frozen).__name__}")
        self._frozen = frozen
        with self.hold_sync():
            self.auto_switches.refresh()  # the "auto" switches hold their values (a trial is suspended)
            self.cull_uniform = self._cull_uniform()
            self.frustum_lines = np.ascontiguousarray(frozen.segments(), np.float32).tobytes()
        return frozen

    def unfreeze_culling(self):
        """Cull against the camera of each frame again (and remove the frustum lines)."""
        self._frozen = None
        with self.hold_sync():
            self.auto_switches.refresh()  # a suspended trial of the "auto" switches resumes
            self.cull_uniform = self._cull_uniform()
            self.frustum_lines = b""

    @property
    def culling_frozen(self) -> bool:
        """True between :meth:`freeze_culling` and :meth:`unfreeze_culling`."""
        return self._frozen is not None

    @property
    def frozen_camera(self):
        """The :class:`~grasswidget.core.teaching.FrozenView` culled against, or None."""
        return self._frozen

    def _set_inspected(self, ids):
        ids = [int(i) for i in ids]
        with self.hold_sync():
            self.inspect_uniform = pack(INSPECT_LAYOUT, {"ids": ids, "n_ids": len(ids)})
            self.inspected = ids

    def inspect(self, ids):
        """Show these blades in the inspector (v0, v1, v2, control polygon, force arrows), every
        frame, computed in the browser by the project's inspect.wgsl; ``[]`` clears. At most 64
        integer ids in [0, N - 1]; anything else raises ValueError naming the limit (nothing changes)."""
        self._set_inspected(check_inspect_ids(ids, len(self.blades)))

    def read_inspected(self, timeout: float = ANSWER_TIMEOUT) -> list:
        """The inspected blades' numbers as ``GrassScene.read_inspected()`` gives them (one dict
        per blade: id, height, stiffness, v0, v1, v2 and the forces of ``reference.FORCE_NAMES``),
        computed by the browser for its current state and parameters. Waits for the answer."""
        ids = list(self.inspected)
        if not ids:
            return []
        # One round trip first: the browser answers in order, and the kernel handles what the browser
        # sent meanwhile (without it, a ball moved just before came out of the first answer wrong).
        self._request({"type": "sync"}, timeout, "read_inspected() from the browser view")
        msg, buffers = self._request({"type": "read_inspected"}, timeout, "read_inspected() from the browser view")
        return self.inspected_from_answer(msg, buffers, ids)

    def inspected_from_answer(self, msg, buffers, ids) -> list:
        """:meth:`read_inspected`'s rows from the browser's "inspected" answer (forces as vec4,
        control points as 3 floats, ``msg["n"]`` blades) for the ids asked about."""
        n = int(msg["n"])
        forces = np.frombuffer(bytes(buffers[0]), np.float32).reshape(n, len(FORCE_NAMES), 4)
        points = np.frombuffer(bytes(buffers[1]), np.float32).reshape(n, 3, 3)
        return inspected_rows(list(ids)[:n], self.blades.height, self.blades.stiffness, self.params.stiffness_scale,
                              points, forces)

    # ------------------------------------------------------------------ requests answered by the browser

    def _request(self, content, timeout, what):
        rid = next(self._ids)
        self._answers[rid] = None
        self.send(dict(content, id=rid))
        try:
            return wait_for(lambda: self._answers.get(rid), timeout, what)
        finally:
            self._answers.pop(rid, None)

    def request_async(self, content, callback):
        """Send a request; ``callback(answer, buffers)`` runs when the browser answers."""
        rid = next(self._ids)
        self._answers[rid] = callback
        self.send(dict(content, id=rid))

    def read_state(self, timeout: float = ANSWER_TIMEOUT) -> dict:
        """The blade state in the browser, as ``GrassField.read_state()`` returns it
        (plus "step_count"). Waits for the browser's answer (TimeoutError if none)."""
        msg, buffers = self._request({"type": "read_state"}, timeout, "read_state() from the browser view")
        n = int(msg["n"])
        state = unpack_state(np.frombuffer(bytes(buffers[0]), np.float32).reshape(n, 4, 4))
        collision = np.frombuffer(bytes(buffers[1]), np.float32)
        state["collision"] = collision[:n].copy()
        state["step_count"] = int(msg["step_count"])
        self.note_reset_flag(float(collision[n]) if len(collision) > n else 0.0)
        return state

    def note_reset_flag(self, value: float) -> bool:
        """The reset flag of the browser's simulation (read with the state): when set, the
        finite check of simulate.wgsl put blades that went non-finite back at rest; warn once
        per cause (NonFiniteStateWarning), as the kernel engine's GrassField.note_reset_flag,
        and ask the page to clear the flag (in order with the steps that follow). Returns
        whether it was set."""
        if not value:
            return False
        self.send({"type": "clear_reset_flag"})
        cause = nonfinite_cause(self.params, self.function_overrides is not None)
        if cause != self._warned_cause:
            self._warned_cause = cause
            warn_nonfinite(nonfinite_message(self.params, self.function_overrides is not None))
        return True

    @staticmethod
    def snapshot_request(size, supersample: int = 1) -> dict:
        """The browser's snapshot message for ``size`` (w, h) pixels: rendered
        ``supersample`` times larger (1..4) and filtered down with
        :func:`grasswidget.core.engine_inputs.export_filter`, as the kernel engine's exports."""
        w, h = int(size[0]), int(size[1])
        if w < 1 or h < 1:
            raise GrassValueError(f"size must be (width, height) of at least 1 pixel; got {tuple(size)!r}")
        return {"type": "snapshot", "width": w, "height": h, "filter": export_filter(supersample)}

    def snapshot(self, size, timeout: float = ANSWER_TIMEOUT, *, supersample: int = 1) -> np.ndarray:
        """(h, w, 4) uint8 RGBA rendered by the browser at ``size`` (waits for the answer);
        ``supersample`` > 1: anti-aliased (see :meth:`snapshot_request`)."""
        msg, buffers = self._request(self.snapshot_request(size, supersample), timeout,
                                     "a snapshot from the browser view")
        return np.frombuffer(bytes(buffers[0]), np.uint8).reshape(int(msg["height"]), int(msg["width"]), 4).copy()

    def _put_wind_back(self, body, old):
        """A refused ``body`` that is still ``params.wind_wgsl`` goes back to ``old`` (the wind the
        page runs), without asking the page again."""
        if self.params.wind_wgsl == body:
            self._reverting_wind = True
            try:
                self.params.wind_wgsl = old
            finally:
                self._reverting_wind = False

    def _request_wind(self, body, old, wait, timeout=ANSWER_TIMEOUT):
        refused = wind_limit_error(body)  # the size limits, before the page's compiler sees it
        if refused is not None:
            self._put_wind_back(body, old)
            if wait:
                raise refused
            self._emit_error(refused)
            return
        shader = with_function_overrides(BrowserShaders.simulate(body), self.function_overrides)
        inspect = with_function_overrides(BrowserShaders.inspect(body), self.function_overrides)  # the same wind
        content = {"type": "compile_simulate", "shader": shader, "passes": {"inspect": inspect}}

        def done(msg, _buffers):
            if msg.get("ok"):
                self._wind_body = body
                self.shaders = dict(self.shaders, simulate=shader, inspect=inspect)
                return None
            err = wind_error_from_messages(msg.get("messages") or [], shader["code"], wind_body(body),
                                           msg.get("message", ""))
            self._put_wind_back(body, old)
            return err

        if not wait:
            self.request_async(content, lambda msg, b: self._emit_error(done(msg, b)))
            return
        msg, buffers = self._request(content, timeout, "compiling wind_wgsl in the browser view")
        err = done(msg, buffers)
        if err is not None:
            raise err

    def set_wind_wgsl(self, body: str, select: bool = True, timeout: float = ANSWER_TIMEOUT):
        """Compile ``body`` as the custom wind in the browser and wait for the answer.

        Raises WindShaderError (with the line in ``body``) when it does not compile;
        the old wind and ``params.wind_wgsl`` stay in force.
        """
        if not isinstance(body, str):
            raise GrassTypeError(f"wind_wgsl must be a str (WGSL function body); got {type(body).__name__}")
        old = self.params.wind_wgsl
        self._reverting_wind = True
        try:
            self.params.wind_wgsl = body
        finally:
            self._reverting_wind = False
        self._request_wind(body, old, wait=True, timeout=timeout)
        if select:
            self.params.wind_field = "custom"

    # ------------------------------------------------------------------ answers

    def on(self, kind, callback):
        """Register ``callback(msg)`` for browser messages of ``kind``: stats, ball, key, error, device_lost,
        steps, pick (ctrl + click: ``origin`` and ``direction`` of the view ray, world space), rest (no
        view of the engine is on screen any more: nothing is drawn, and no stats come, until one is)."""
        self._listeners[kind].append(callback)

    def _emit_error(self, err):
        if err is None:
            return
        self.errors = (self.errors + [str(err)])[-20:]
        for cb in self._listeners["error"]:
            cb(err)

    def handle_message(self, content: dict, buffers=()):
        """Handle one message from the page (what engine.js sends over the comm:
        ``{"type": "ball" | "steps" | "stats" | ..., ...}``); never raises."""
        self._on_browser_msg(self, content, buffers)

    def _on_browser_msg(self, _widget, content, buffers):
        # Never let a front-end message raise into the notebook.
        try:
            kind = content.get("type")
            rid = content.get("id")
            if rid is not None and rid in self._answers:
                waiting = self._answers[rid]
                if callable(waiting):
                    self._answers.pop(rid, None)
                    waiting(content, list(buffers or []))
                elif kind == "error":
                    self._answers[rid] = None
                    self._emit_error(RuntimeError(content.get("message", "browser error")))
                else:
                    self._answers[rid] = (content, list(buffers or []))
                return
            if kind == "stats":
                self.last_stats = dict(content)
                self.step_count_hint = int(content.get("step_count") or 0)
                self.auto_switches.on_stats(content)
            if kind == "error":
                self._emit_error(RuntimeError(content.get("message", "browser error")))
                return
            for cb in self._listeners.get(kind, ()):
                cb(content)
        except Exception as err:  # noqa: BLE001 - report, never raise into the notebook
            try:
                self._emit_error(err)
            except Exception:
                pass

    def close(self):
        try:
            self.params.unobserve(self._on_params)
        except ValueError:
            pass
        own_layout = self.layout  # a widget of its own, which ipywidgets' close leaves open
        super().close()
        own_layout.close()
