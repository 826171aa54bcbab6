"""Every use of private or internal API of pygfx, wgpu, jupyter-rfb, rendercanvas, ipykernel and ipywidgets.

Nothing else in grasswidget touches a name that starts with an underscore in
another package, or an internal module of one. Each function below names what
it relies on and the version it was checked against (:data:`CHECKED`);
``tests/test_compat.py`` checks every one of them against the installed packages,
so an upgrade that changes one fails there, by name, instead of somewhere deep in
a render. Importing this module imports none of those packages.

Events: jupyter-rfb 1.0 sends events in its current format (``type``,
``timestamp``, ``ratio``) and, for older consumers, the legacy one
(``event_type``, ``time_stamp``, ``pixel_ratio``); rendercanvas 2.7's Jupyter
canvas still asks for the legacy one (pygfx's controllers read it). Our handlers
read events only through :func:`event_type`, :func:`event_ratio` and
:func:`with_ratio`, which accept both, so they work before and after the switch.
"""

from __future__ import annotations

from .errors import GrassValueError, UpstreamChangedError

__all__ = [
    "CHECKED",
    "PRIVATE_USES",
    "installed_versions",
    "gpu_buffer",
    "sync_buffer",
    "forget_pending_upload",
    "default_device_exists",
    "poll_device",
    "promise_settled",
    "write_timestamp",
    "add_pass_begin_hook",
    "render_pipeline_container_class",
    "set_render_pipeline_container_class",
    "compute_pipeline_container_class",
    "set_compute_pipeline_container_class",
    "renderer_depth_texture",
    "renderer_pick_texture",
    "copy_output_when_exact",
    "keep_renderstates",
    "still_directional_light_class",
    "begin_target_render_pass",
    "render_target_formats",
    "ddaa_fragment_wgsl",
    "pygfx_event_class",
    "held_orbit_controller_class",
    "pygfx_event_fields",
    "event_type",
    "event_ratio",
    "with_ratio",
    "kernel_parent_ident",
    "kernel_has_shell_socket",
    "kernel_shell_socket",
    "kernel_dispatch_comm",
    "kernel_requeue_shell",
    "timed_jupyter_canvas_class",
    "encode_frame",
    "cancel_draw",
    "DrawCancelled",
    "observe_view_visibility",
    "set_view_visibility",
    "observe_frame_feedback",
    "set_frame_feedback",
    "fixed_rfb_esm",
    "widget_registry",
    "marimo_anywidget_element",
]

#: The versions every use below was written and tested against.
CHECKED = {"pygfx": "0.17.0", "wgpu": "0.32.0", "jupyter_rfb": "1.0.2", "rendercanvas": "2.7.2", "ipykernel": "7.4.0",
           "ipywidgets": "8.1.9", "marimo": "0.25.2"}

#: (package, what is used, why): the table ``tests/test_compat.py`` walks.
PRIVATE_USES = (
    ("pygfx", "Buffer._wgpu_object", "the GPU buffer behind a pygfx Buffer (readbacks, copies)"),
    ("pygfx", "renderers.wgpu.engine.update.ensure_wgpu_object / update_resource",
     "create a buffer's GPU object and upload pending data outside a render (step(), readbacks)"),
    ("pygfx", "resources._base.resource_update_registry._syncable",
     "drop a destroyed buffer's pending upload so no later render writes to it"),
    ("pygfx", "renderers.wgpu.engine.shared.Shared.get_instance",
     "whether pygfx has created its device yet (the adapter choice must come first)"),
    ("pygfx", "renderers.wgpu.engine.renderstate._renderstate_instance_cache",
     "the render states (lights, blender) pygfx keeps only while a renderer uses them: kept for good, so that a new "
     "scene's renderer reuses every cached pipeline instead of compiling them all again (keep_renderstates)"),
    ("pygfx", "renderers.wgpu.engine.pipeline.RenderPipelineContainer",
     "the class pygfx instantiates per render shader; replaced to issue draw_indirect"),
    ("pygfx", "renderers.wgpu.engine.pipeline.ComputePipelineContainer",
     "the class pygfx instantiates per compute shader; replaced to issue dispatch_workgroups_indirect"),
    ("pygfx", "WgpuRenderer._blender.get_color_attachments(pass_type) / get_depth_attachment()",
     "a render pass on the renderer's colour, pick and depth targets (loaded), in our own command encoder: the "
     "occlusion culling's second-phase draws, without a second render() call (begin_target_render_pass)"),
    ("pygfx", "renderstate.blender._texture_info (format of 'color', 'pick', 'depth')",
     "the formats of the render pass a renderstate draws into: a render bundle of the blade draws must name "
     "them (render_target_formats, gpu/draw_bundles.py)"),
    ("pygfx", "DDAAPass._template_vars and shader.templating.apply_templating of 'pygfx.ddaa2.wgsl'",
     "pygfx's DDAA anti-aliasing shader, templated as a DDAAPass templates it, run in a compute pass "
     "(gpu/compute_ddaa.py: a full-screen fragment pass cost 1.4 ms of a 4.6 ms frame on the H100)"),
    ("pygfx", "DirectionalLight._gfx_update_uniform_buffer",
     "overridden by the scene's sun (still_directional_light_class): pygfx calls it for every directional light in "
     "every render and it redoes a look_at each time (0.6 ms of a 4.5 ms host frame on lavapipe's host), though "
     "the light rarely moves; the override skips it while neither the light nor its target moved"),
    ("pygfx", "WgpuRenderer._output_pass (an OutputPass: render(encoder, color, depth, target), gamma), "
     "WgpuRenderer._canvas_context, Texture._wgpu_usage",
     "the last pass of every flush, a full-screen pass that filters the colour target into the canvas texture: "
     "where it is an exact copy (same format and size, gamma 1) a texture copy instead; on lavapipe the pass "
     "cost 2.6 ms of a 23 ms frame (copy_output_when_exact)"),
    ("pygfx", "WgpuRenderer._blender.get_texture('depth')",
     "the renderer's depth32float texture (usage COPY_SRC), copied into the occlusion culling's depth pyramid"),
    ("pygfx", "WgpuRenderer._blender.get_texture('pick')",
     "the renderer's pick texture (rgba16uint), read whole by benchmarks/occlusion_shown.py to count the blades a "
     "picture shows (get_pick_info reads one pixel a call)"),
    ("pygfx", "OrbitController._update_rotate/_update_zoom/_update_pan, _get_camera_state, _set_camera_state, "
     "_last_cam_state",
     "the controller's per-step hooks, to hold every orbit, zoom and pan step to OrbitLimits"),
    ("pygfx", "WorldObject._update_object",
     "overridden by the blade inspector: pygfx calls it on every object before each render (its docstring: "
     "'a good time for lazy updates'); the inspector refreshes the simulation uniforms it reads"),
    ("pygfx", "Material._wgpu_get_pick_info",
     "overridden by GrassMaterial: renderer.get_pick_info asks the material to decode a pick value (blade id)"),
    ("pygfx", "renderers.wgpu.engine.renderer.EVENT_TYPE_MAP",
     "pygfx event classes, to forward canvas events to controllers without a pick readback"),
    ("wgpu", "GPUDevice._poll", "process finished GPU work without blocking (statistics)"),
    ("wgpu", "GPUPromise._state", "whether a map_async promise has settled (statistics never block)"),
    ("wgpu", "backends.wgpu_native.extras.write_timestamp", "GPU timestamps inside pygfx's render pass"),
    ("wgpu", "backends.wgpu_native.GPUCommandEncoder.begin_compute_pass / begin_render_pass (wrapped)",
     "pygfx begins its passes itself: a hook adds timestamp_writes to every pass begun (add_pass_begin_hook; "
     "gpu.stats.PassTimer: the GPU time of an 'auto' switch's trial frame)"),
    ("rendercanvas", "jupyter.RenderCanvas._rc_present_bitmap",
     "the Jupyter canvas's hook that receives each rendered frame; timed (readback ms on the stats line)"),
    ("rendercanvas", "jupyter.RenderCanvas._rc_close",
     "the Jupyter canvas's close hook; extended to close what jupyter-rfb leaves open (its Layout, its output widget)"),
    ("jupyter_rfb", "RemoteFrameBuffer._output_context",
     "the Output widget jupyter-rfb makes per canvas for callback errors and never closes (closed with the canvas)"),
    ("rendercanvas", "jupyter.RenderCanvas._event_compatibility",
     "which event format the Jupyter canvas asks jupyter-rfb for (see event_type)"),
    ("jupyter_rfb", "RemoteFrameBuffer._rfb_send_frame, with its state _rfb_frame_index, _rfb_last_frame, "
     "_rfb_stats, _rfb_last_confirmed_index, _rfb_pending_display, _rfb_last_resize_event, _rfb_lossless_draw_info, "
     "_rfb_schedule_lossless_draw, _rfb_cancel_lossless_draw; jupyter_rfb._utils.array2compressed",
     "replaced by the timed canvas's: a frame equal to the last is not sent again, frames are encoded on a worker "
     "thread while the next renders (timed_jupyter_canvas_class); the message it sends is jupyter-rfb's"),
    ("rendercanvas", "a draw function's exception named DrawCancelled (BaseRenderCanvas._draw_and_present)",
     "the kernel view's draw renders nothing when it knows nothing changed (cancel_draw)"),
    ("jupyter_rfb", "RemoteFrameBuffer._rfb_handle_msg", "turns browser messages into events of both formats"),
    ("jupyter_rfb", "RemoteFrameBuffer._has_visible_views",
     "the synced trait its front end sets from an IntersectionObserver per view: whether any view is on screen "
     "(jupyter-rfb draws only then; the kernel view stops its clock while it is False: observe_view_visibility; set_view_visibility sets it in tests)"),
    ("jupyter_rfb", "RemoteFrameBuffer._frame_feedback",
     "the synced trait its front end sets when a frame arrived (index, timestamp): the kernel view's stats "
     "say how long ago the newest frame arrived (observe_frame_feedback); redeclared on the timed canvas "
     "without ipywidgets' echo (one message less per frame: timed_jupyter_canvas_class)"),
    ("jupyter_rfb", "RemoteFrameBuffer._esm (the text of renderview.js)",
     "one line corrected: its 'input' handler clears the hidden key input through this.focus_el, a name "
     "renderview.js never sets, so every character typed into the view threw a page error (fixed_rfb_esm); "
     "its acknowledgement of each frame made one of every ACK_EVERY frames at once, the others within "
     "ACK_DELAY_MS (throttled_ack_esm)"),
    ("ipywidgets", "widgets.widget._instances",
     "the registry of open widgets (model id -> widget): not a holder when a re-run cell decides whether to close "
     "its earlier widget (cell_rerun.holder_of)"),
    ("marimo", "runtime context per thread (_runtime.context.types._THREAD_LOCAL_CONTEXT, a threading.local)",
     "marimo's element of an anywidget made where no cell runs (a widget message's handler): made in a helper "
     "thread, which has no marimo context, as marimo makes it outside a notebook (marimo_anywidget_element)"),
    ("ipykernel", "Kernel._parent_ident",
     "the routing identity of the running cell's request, to hand deferred shell messages back (browser.kernel_pump)"),
    ("ipykernel", "Kernel.shell_channel_thread.manager.get_shell_channel_to_subshell_pair(None).to_socket",
     "the inproc socket the main shell's messages arrive on (ipykernel 7 subshells); read while a cell waits"),
    ("ipykernel", "Kernel.shell_stream.socket", "the shell socket of a kernel without a shell channel thread"),
    ("ipykernel", "Kernel.dispatch_shell(frames, concurrent=True)",
     "handle a comm message now, inside a running cell (what ipykernel does for a cell awaiting a widget reply)"),
    ("ipykernel", "Kernel.shell_main(subshell_id, frames)",
     "the main shell's message handler: deferred messages are handed back to it, in order, after the cell"),
    ("ipykernel", "Kernel.do_one_iteration",
     "present in ipykernel 6 (jupyter-ui-poll pumps it); absent with the shell channel thread"),
)


def installed_versions() -> dict:
    """{package: installed version} for the packages of :data:`CHECKED`."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in CHECKED:
        try:
            out[name] = version(name.replace("_", "-"))
        except PackageNotFoundError:
            out[name] = None
    return out


# ------------------------------------------------------------------ pygfx resources


def gpu_buffer(buffer):
    """The wgpu buffer behind a pygfx ``Buffer``, or None before it exists (pygfx 0.17: ``_wgpu_object``)."""
    return getattr(buffer, "_wgpu_object", None)


def sync_buffer(buffer):
    """Create a pygfx ``Buffer``'s GPU object if needed and upload pending CPU data; return the wgpu buffer."""
    from pygfx.renderers.wgpu.engine.update import ensure_wgpu_object, update_resource

    wgpu_buffer = ensure_wgpu_object(buffer)
    update_resource(buffer)
    return wgpu_buffer


def forget_pending_upload(buffer) -> bool:
    """Take a buffer out of pygfx's global upload registry (before destroying it).

    Returns False when this pygfx has no such registry (then the caller should
    leave the buffer to the garbage collector instead of destroying it).
    """
    try:
        from pygfx.resources._base import resource_update_registry

        pending = resource_update_registry._syncable
    except (ImportError, AttributeError):
        return False
    pending.discard(buffer)
    return True


def default_device_exists() -> bool:
    """Whether pygfx has created its shared device (after which the adapter is fixed)."""
    from pygfx.renderers.wgpu.engine.shared import Shared

    return Shared.get_instance() is not None


# ------------------------------------------------------------------ wgpu


def poll_device(device):
    """Let wgpu process finished work without blocking (wgpu 0.32: ``GPUDevice._poll``); no-op if absent."""
    poll = getattr(device, "_poll", None)
    if poll is not None:
        poll()


def promise_settled(promise) -> bool:
    """Whether a ``GPUPromise`` is fulfilled or rejected (wgpu 0.32: ``_state``).

    An unknown wgpu that has no such state reports True (``sync_wait`` is then quick).
    """
    state = getattr(promise, "_state", None)
    if state is None:
        return True
    return "fulfilled" in str(state) or "rejected" in str(state)


def write_timestamp(render_pass, query_set, index):
    """Write a GPU timestamp inside a pass (wgpu-native's extras; needs timestamp-query-inside-passes)."""
    from wgpu.backends.wgpu_native.extras import write_timestamp as _write

    _write(render_pass, query_set, index)


_PASS_BEGIN_HOOKS = []  # the hooks add_pass_begin_hook added, called in order
_PASS_BEGINS_WRAPPED = []  # [True] once wgpu-native's pass begins are wrapped


def add_pass_begin_hook(hook):
    """Call ``hook(kind, kwargs)`` before every pass wgpu-native begins: ``kind`` "compute" or "render",
    ``kwargs`` the pass's keyword arguments, which it may change (e.g. add ``timestamp_writes``). Hooks run
    in the order added; returns a function that removes this one. pygfx begins its passes itself, so no pass
    descriptor can be handed to it: wgpu-native's ``GPUCommandEncoder.begin_compute_pass`` and
    ``begin_render_pass`` are wrapped, once (the first hook added). Used by
    :class:`grasswidget.gpu.stats.PassTimer` and the benchmarks' pass profiles."""
    if not _PASS_BEGINS_WRAPPED:
        from wgpu.backends import wgpu_native

        cls = getattr(wgpu_native, "GPUCommandEncoder", None)
        for name, kind in (("begin_compute_pass", "compute"), ("begin_render_pass", "render")):
            original = getattr(cls, name, None)
            if original is None:
                raise UpstreamChangedError(f"wgpu internals changed: wgpu_native.GPUCommandEncoder.{name} not found")

            def begin(self, *args, _original=original, _kind=kind, **kwargs):
                for each in tuple(_PASS_BEGIN_HOOKS):
                    each(_kind, kwargs)
                return _original(self, *args, **kwargs)

            begin.__name__ = name
            begin.__doc__ = original.__doc__
            setattr(cls, name, begin)
        _PASS_BEGINS_WRAPPED.append(True)
    _PASS_BEGIN_HOOKS.append(hook)

    def remove():
        if hook in _PASS_BEGIN_HOOKS:
            _PASS_BEGIN_HOOKS.remove(hook)

    return remove


# ------------------------------------------------------------------ pygfx engine

#: The head of the fragment entry point of pygfx 0.17's ddaa2.wgsl (see ddaa_fragment_wgsl).
DDAA_FRAGMENT_HEAD = "@fragment\nfn fs_main(varyings: Varyings) -> @location(0) vec4<f32> {"


def ddaa_fragment_wgsl(effect_pass) -> str:
    """The WGSL of pygfx's DDAA fragment shader (``pygfx.ddaa2.wgsl``) templated with the
    settings of ``effect_pass`` (a pygfx ``DDAAPass``: its template variables, e.g. the
    edge-search steps of ``max_edge_iters``), as pygfx templates it for its full-screen pass.
    It reads ``colorTex`` / ``texSampler`` at ``varyings.texCoord`` and starts its entry point
    with :data:`DDAA_FRAGMENT_HEAD`; UpstreamChangedError when that is no longer so."""
    from pygfx.renderers.wgpu.shader.templating import apply_templating

    variables = dict(effect_pass._template_vars)
    code = apply_templating("{$ include 'pygfx.ddaa2.wgsl' $}", **variables)
    if code.count(DDAA_FRAGMENT_HEAD) != 1 or "varyings.texCoord" not in code:
        raise UpstreamChangedError("pygfx's ddaa2.wgsl no longer has the fragment entry point "
                                   f"{DDAA_FRAGMENT_HEAD!r} reading varyings.texCoord")
    return code



#: Render states made by pygfx, kept alive here: {their hash: the state}. A handful at most (one
#: per combination of light counts and blender set-up).
_KEPT_RENDERSTATES: dict = {}


def keep_renderstates() -> int:
    """Keep every render state pygfx has made so far alive for the rest of the process;
    returns how many are kept.

    pygfx 0.17 holds a render state (the lights' and the blender's bindings, one bind group
    layout) in a weak dictionary, so it dies with the last renderer that used it. The next
    renderer makes a new one whose bind group layout is a new object, and every pipeline
    cache key of pygfx (``renderers.wgpu.engine.pipeline``: pipeline layouts, pipelines)
    names that object: a new GrassScene made after the last one was released (or a new
    widget after the last was closed) compiled all its ~11 render pipelines again (0.1-0.4 s
    on lavapipe) and left the old ones in pygfx's LRU caches (128 entries each): 2.6 MiB a
    scene drawn once on lavapipe.
    Kept, the states are found again by their hash and the cached pipelines are reused.
    """
    from pygfx.renderers.wgpu.engine import renderstate

    cache = getattr(renderstate, "_renderstate_instance_cache", None)
    if cache is None or not hasattr(cache, "items"):
        raise UpstreamChangedError("pygfx internals changed: renderstate._renderstate_instance_cache not found")
    for key, state in list(cache.items()):
        _KEPT_RENDERSTATES.setdefault(key, state)
    return len(_KEPT_RENDERSTATES)


def render_pipeline_container_class():
    """The class pygfx's pipeline module instantiates for each render shader."""
    from pygfx.renderers.wgpu.engine import pipeline

    return pipeline.RenderPipelineContainer


def set_render_pipeline_container_class(cls):
    """Make pygfx instantiate ``cls`` for render shaders from now on (see gpu/indirect.py)."""
    from pygfx.renderers.wgpu.engine import pipeline

    if not hasattr(pipeline, "RenderPipelineContainer"):
        raise UpstreamChangedError("pygfx internals changed: engine.pipeline.RenderPipelineContainer not found")
    pipeline.RenderPipelineContainer = cls


def compute_pipeline_container_class():
    """The class pygfx's pipeline module instantiates for each compute shader."""
    from pygfx.renderers.wgpu.engine import pipeline

    return pipeline.ComputePipelineContainer


def set_compute_pipeline_container_class(cls):
    """Make pygfx instantiate ``cls`` for compute shaders from now on (see gpu/indirect.py)."""
    from pygfx.renderers.wgpu.engine import pipeline

    if not hasattr(pipeline, "ComputePipelineContainer"):
        raise UpstreamChangedError("pygfx internals changed: engine.pipeline.ComputePipelineContainer not found")
    pipeline.ComputePipelineContainer = cls


def still_directional_light_class():
    """A subclass of pygfx's ``DirectionalLight`` that lights exactly like it, but
    recomputes its direction (and re-aims itself, a ``look_at``) only when it, its target
    or its parent camera moved since the last render.

    pygfx 0.17 calls ``DirectionalLight._gfx_update_uniform_buffer`` for every directional
    light in every ``render()``; it always ends in ``look_at``, whose rotation update marks
    the light's world transform changed, so the light's own uniforms are uploaded again
    at the next render too. The override compares the ``last_modified`` stamps of the
    light's, its target's and (when the light rides a camera) the camera's world
    transforms, taken after the update, and returns early while none advanced.
    """
    import pygfx as gfx

    base = gfx.DirectionalLight
    if not callable(getattr(base, "_gfx_update_uniform_buffer", None)):
        raise UpstreamChangedError("pygfx internals changed: DirectionalLight._gfx_update_uniform_buffer not found")

    class StillDirectionalLight(base):
        """A ``pygfx.DirectionalLight`` that skips its per-render update while it stands still."""

        _grass_moved_key = None

        def _moved_key(self):
            parent = self.parent
            camera = parent.world.last_modified if isinstance(parent, gfx.Camera) else None
            return self.world.last_modified, self.target.world.last_modified, camera, id(self.target)

        def _gfx_update_uniform_buffer(self):
            if self._grass_moved_key is not None and self._moved_key() == self._grass_moved_key:
                return
            super()._gfx_update_uniform_buffer()
            self._grass_moved_key = self._moved_key()

    return StillDirectionalLight


def begin_target_render_pass(renderer, encoder, pass_type="opaque"):
    """Begin a render pass in ``encoder`` on the targets ``renderer``'s last ``render()`` drew
    into (colour, and pick / depth where pygfx has them; loaded, unless a clear is pending),
    with the full-size viewport, as pygfx 0.17's ``render()`` begins the pass of one pass type
    (``renderer._blender.get_color_attachments(pass_type)`` and ``get_depth_attachment()``).
    Draw into it with pipeline containers' ``draw(render_pass, renderstate)`` of that render.
    ``pass_type``: the drawn material's ``alpha_method``; "weighted" is refused (its pass
    needs pygfx's resolve afterwards)."""
    blender = getattr(renderer, "_blender", None)
    if blender is None or not hasattr(blender, "get_color_attachments") or not hasattr(blender, "get_depth_attachment"):
        raise UpstreamChangedError("pygfx internals changed: WgpuRenderer._blender attachments not found")
    if pass_type == "weighted":
        raise UpstreamChangedError("begin_target_render_pass: the weighted pass type needs pygfx's own resolve")
    render_pass = encoder.begin_render_pass(color_attachments=blender.get_color_attachments(pass_type),
                                            depth_stencil_attachment=blender.get_depth_attachment(),
                                            occlusion_query_set=None)
    width, height = renderer.physical_size
    render_pass.set_viewport(0, 0, width, height, 0, 1)
    return render_pass


def render_target_formats(renderstate) -> tuple:
    """((colour formats...), depth format or None) of the render pass pygfx 0.17 draws a
    non-weighted pass type into with ``renderstate`` (what it hands to pipeline containers'
    ``draw``): its blender's "color" target, then "pick" where the blender has one, and
    "depth" (``renderstate.blender._texture_info``), in the pass's attachment order."""
    info = getattr(getattr(renderstate, "blender", None), "_texture_info", None)
    if not isinstance(info, dict) or "color" not in info:
        raise UpstreamChangedError("pygfx internals changed: renderstate.blender._texture_info not found")
    colors = [info["color"]["format"]]
    if "pick" in info:
        colors.append(info["pick"]["format"])
    depth = info["depth"]["format"] if "depth" in info else None
    return tuple(colors), depth


def renderer_pick_texture(renderer):
    """The wgpu pick texture a pygfx ``WgpuRenderer`` writes object and blade ids into
    (rgba16uint, 8 bytes a pixel: pygfx's 20 bits of object id, then the material's own bits),
    or None before its first render (pygfx 0.17: ``renderer._blender.get_texture("pick")``)."""
    blender = getattr(renderer, "_blender", None)
    if blender is None or not hasattr(blender, "get_texture"):
        raise UpstreamChangedError("pygfx internals changed: WgpuRenderer._blender.get_texture not found")
    return blender.get_texture("pick")


def renderer_depth_texture(renderer):
    """The wgpu depth texture a pygfx ``WgpuRenderer`` renders into (depth32float, usage
    RENDER_ATTACHMENT | COPY_SRC | TEXTURE_BINDING; the physical size), or None before its
    first render (pygfx 0.17: ``renderer._blender.get_texture("depth")``)."""
    blender = getattr(renderer, "_blender", None)
    if blender is None or not hasattr(blender, "get_texture"):
        raise UpstreamChangedError("pygfx internals changed: WgpuRenderer._blender.get_texture not found")
    return blender.get_texture("depth")


def copy_output_when_exact(renderer) -> bool:
    """Let ``renderer`` (a pygfx 0.17 ``WgpuRenderer``, before its first render) end each flush
    with a texture copy instead of its output pass wherever the pass is an exact copy.

    pygfx's output pass (``renderer._output_pass``, an ``OutputPass``) draws the finished
    colour target (rgba8unorm-srgb) into the canvas texture through a full-screen fragment
    pass: a filter (a one-tap "linear" one at pixel ratio 1), the gamma and a premultiplied
    alpha. When the two textures have the same format and size, the gamma is 1 and the
    colour target is opaque, that is a copy of the bytes; on a CPU adapter the pass cost
    2.6 ms of the 23 ms cis565 2^13 frame, the copy a few hundredths.

    The copy is taken when the colour and target textures have the same format and size,
    the pass's gamma is 1, the target can be copied into and the renderer's ``opaque_output``
    attribute is True (set here: the renderer's caller promises an opaque picture, e.g. a
    sky drawn over every pixel; set it False where alpha below 1 reaches the colour target,
    which the pass would premultiply). Otherwise the pass runs as before. The canvas
    (a rendercanvas context) is configured again with COPY_DST added to its usage; a pygfx
    Texture target gets COPY_DST among the usages pygfx creates it with.
    ``renderer.output_copies`` counts the flushes that ended with the copy.
    Returns whether the renderer's target accepts the copy.
    """
    import wgpu

    output_pass = getattr(renderer, "_output_pass", None)
    if output_pass is None or not callable(getattr(output_pass, "render", None)) or not hasattr(output_pass, "gamma"):
        raise UpstreamChangedError("pygfx internals changed: WgpuRenderer._output_pass (OutputPass) not found")
    target = renderer.target
    context = getattr(renderer, "_canvas_context", None)
    copy_dst = wgpu.TextureUsage.COPY_DST
    if context is not None:
        config = context.get_configuration() if hasattr(context, "get_configuration") else None
        if not config:
            return False
        usage = config.get("usage", wgpu.TextureUsage.RENDER_ATTACHMENT)
        if isinstance(usage, int) and not usage & copy_dst:
            context.configure(device=config["device"], format=config["format"], usage=usage | copy_dst,
                              view_formats=config.get("view_formats", ()),
                              alpha_mode=config.get("alpha_mode", "opaque"))
    elif hasattr(target, "_wgpu_usage"):
        target._wgpu_usage |= copy_dst
    else:
        return False
    if getattr(output_pass, "_grass_copies", False):
        return True
    renderer.opaque_output = True
    renderer.output_copies = 0  # flushes that ended with the copy
    draw_pass = output_pass.render

    def render(command_encoder, color_tex, depth_tex, target_tex):
        src, dst = getattr(color_tex, "texture", None), getattr(target_tex, "texture", None)
        if (src is not None and dst is not None and getattr(renderer, "opaque_output", False)
                and float(output_pass.gamma) == 1.0 and src.format == dst.format
                and tuple(src.size) == tuple(dst.size) and src.mip_level_count == 1 and dst.mip_level_count == 1
                and src.usage & wgpu.TextureUsage.COPY_SRC and dst.usage & copy_dst):
            command_encoder.copy_texture_to_texture({"texture": src}, {"texture": dst}, tuple(src.size))
            renderer.output_copies += 1
            return None
        return draw_pass(command_encoder, color_tex, depth_tex, target_tex)

    output_pass.render = render
    output_pass._grass_copies = True
    return True


def held_orbit_controller_class(hold):
    """A subclass of pygfx's ``OrbitController`` whose every orbit, zoom and pan step
    is passed through ``hold(controller, position, target, state)``, which returns
    ``(position, rotation, target)`` or None (the step stands), before the camera sees it.

    It overrides the controller's per-action hooks ``_update_rotate``,
    ``_update_zoom`` and ``_update_pan`` (the extension points pygfx's own
    controllers use) and reads/writes the step's camera state with
    ``_get_camera_state``, ``_last_cam_state`` and ``_set_camera_state``. The target is set through the
    public ``target`` property.
    """
    import pygfx as gfx

    base = gfx.OrbitController
    for name in ("_update_rotate", "_update_zoom", "_update_pan", "_get_camera_state", "_set_camera_state"):
        if not callable(getattr(base, name, None)):
            raise UpstreamChangedError(f"pygfx internals changed: OrbitController.{name} not found")

    class HeldOrbitController(base):
        def _hold(self):
            state = self._get_camera_state()
            # the step's result: _get_camera_state() gives it while a (damped) action runs, but the
            # camera's own state for a direct call (rotate(..., animate=False)); _last_cam_state has it both times
            position = self._last_cam_state.get("position", state["position"])
            held = hold(self, position, self.target, state)
            if held is not None:
                position, rotation, target = held
                self.target = target
                self._set_camera_state({"position": position, "rotation": rotation})

        def _update_rotate(self, delta):
            super()._update_rotate(delta)
            self._hold()

        def _update_zoom(self, delta):
            super()._update_zoom(delta)
            self._hold()

        def _update_pan(self, delta, *, vecx, vecy):
            super()._update_pan(delta, vecx=vecx, vecy=vecy)
            self._hold()

    return HeldOrbitController


def pygfx_event_class(name):
    """pygfx's event class for a canvas event type (e.g. "pointer_down"), or None."""
    from pygfx.renderers.wgpu.engine.renderer import EVENT_TYPE_MAP

    return EVENT_TYPE_MAP.get(name)


def pygfx_event_fields(event) -> dict:
    """Keyword arguments for a pygfx event class from a canvas event of either format
    (pygfx 0.17 reads ``time_stamp``; ``type``, ``target`` and ``root`` are left out)."""
    fields = {k: v for k, v in event.items() if k not in ("type", "target", "root")}
    if "timestamp" in fields and "time_stamp" not in fields:
        fields["time_stamp"] = fields["timestamp"]
    return fields


# ------------------------------------------------------------------ canvas events


def event_type(event) -> str | None:
    """The type of a canvas event dict, in the current format (``type``) or the legacy one (``event_type``)."""
    return event.get("type", event.get("event_type"))


def event_ratio(event):
    """The pixel ratio of a resize event (``ratio``, legacy ``pixel_ratio``), or None."""
    return event.get("ratio", event.get("pixel_ratio"))


def with_ratio(event, ratio):
    """A copy of a resize event with its pixel ratio set to ``ratio`` under whichever keys it has."""
    event = dict(event)
    for key in ("ratio", "pixel_ratio"):
        if key in event:
            event[key] = ratio
    return event


# ------------------------------------------------------------------ ipykernel


def kernel_parent_ident(kernel, channel: str = "shell") -> bytes:
    """The routing identity of the request the kernel is running on ``channel``
    (ipykernel 7.4: ``Kernel._parent_ident[channel]``, kept there for backward
    compatibility); ``b""`` when the kernel has none."""
    idents = getattr(kernel, "_parent_ident", None)
    if idents is None:
        return b""
    return idents[channel]


def kernel_has_shell_socket(kernel) -> bool:
    """Whether ``kernel`` receives shell messages on a socket we can read while a cell
    runs (ipykernel 7: a shell channel thread, or no ``do_one_iteration`` to pump);
    False for ipykernel 6 (use jupyter-ui-poll there)."""
    return getattr(kernel, "shell_channel_thread", None) is not None or not hasattr(kernel, "do_one_iteration")


def kernel_shell_socket(kernel):
    """The zmq socket the main shell's messages arrive on (ipykernel 7.4: the shell
    channel thread's inproc pair to the main shell, ``manager.get_shell_channel_to_subshell_pair(None)
    .to_socket``; without that thread the shell stream's socket)."""
    thread = getattr(kernel, "shell_channel_thread", None)
    if thread is not None:
        return thread.manager.get_shell_channel_to_subshell_pair(None).to_socket
    return kernel.shell_stream.socket


def kernel_dispatch_comm(kernel, frames):
    """The coroutine that handles one shell message (``frames``, as read from
    :func:`kernel_shell_socket`) at once, alongside the running cell (ipykernel 7.4:
    ``dispatch_shell(frames, concurrent=True)``, as it does for a cell awaiting a widget reply)."""
    return kernel.dispatch_shell(frames, concurrent=True)


def kernel_requeue_shell(kernel, frames):
    """Hand a shell message back to the kernel's loop, to run after the current cell in
    the order handed back (ipykernel 7.4: ``io_loop.add_callback(shell_main, None, frames)``;
    ``None`` is the main shell's subshell id)."""
    kernel.io_loop.add_callback(kernel.shell_main, None, frames)


# ------------------------------------------------------------------ rendercanvas


def encode_frame(array, quality: int) -> tuple:
    """``(mimetype, bytes)`` of an (h, w, 4) or (h, w, 3) uint8 frame: a JPEG of ``quality`` (1..99;
    Pillow, straight from the RGBA pixels with no copy, chroma subsampled 4:2:0, Pillow's encoder
    releasing the GIL while it runs), or a lossless PNG when ``quality`` is 100 or Pillow is missing
    (jupyter-rfb's own encoder then)."""
    import numpy as np

    quality = int(quality)
    if quality < 100 and array.ndim == 3 and array.shape[2] in (3, 4) and array.dtype == np.uint8:
        try:
            import io

            from PIL import Image
        except ImportError:
            Image = None
        if Image is not None:
            h, w, channels = array.shape
            data = np.ascontiguousarray(array)
            mode = "RGBX" if channels == 4 else "RGB"
            image = Image.frombuffer(mode, (w, h), data, "raw", mode, 0, 1)
            out = io.BytesIO()
            image.save(out, format="JPEG", quality=max(1, quality), subsampling="4:2:0")
            return "image/jpeg", out.getvalue()
    from jupyter_rfb._utils import array2compressed

    return array2compressed(array, quality)


def timed_jupyter_canvas_class():
    """A subclass of rendercanvas's Jupyter ``RenderCanvas`` that streams frames as the kernel view needs.

    - ``on_present(perf_counter_seconds)`` (when set) is called as each rendered frame's pixels
      arrive, before they are sent (rendercanvas 2.7: the ``_rc_present_bitmap`` hook);
    - a frame whose pixels equal the last frame's is not encoded or sent again
      (``skip_unchanged``, default True; counted in ``unchanged_frames``), unless the page may not
      show that frame (:meth:`frame_owed`: after a resize event, which a new view or a page reload
      sends, or a view coming back on screen); the lossless picture jupyter-rfb sends 0.3 s after the
      last lossy frame still comes;
    - frames are encoded (:func:`encode_frame`) and sent on one worker thread, in order, so the kernel
      renders the next frame meanwhile (a frame sent from the event loop would wait for that render);
      jupyter-rfb's limit of frames in flight (``max_buffered_frames``) counts the frames being
      encoded. Without a running event loop (a script, a test) a frame is encoded and sent at once;
    - ``on_transport(kind, seconds)`` (when set) is called on the event loop's thread with
      ``("encode", s)`` and ``("send", s)`` for each frame streamed (not for the lossless redraws) and
      ``("unchanged", 0.0)`` for each frame not sent again;
    - closed, it also closes its Layout and jupyter-rfb's output widget (``_rc_close``) and its worker;
    - the page acknowledges every :data:`ACK_EVERY`-th frame (and any other within :data:`ACK_DELAY_MS`:
      :func:`throttled_ack_esm`), and its acknowledgement (jupyter-rfb's ``_frame_feedback``) is not
      echoed back to the page: ipywidgets 8 echoes every trait a front end sets, one more message per
      acknowledgement through the kernel, the server and the page, and no view reads that trait.

    jupyter-rfb 1.0.2's ``_rfb_send_frame`` is replaced (its frame counter, stats and lossless
    redraw are kept as it keeps them; see :data:`PRIVATE_USES`).
    """
    import asyncio
    import concurrent.futures
    import time

    import numpy as np
    import traitlets
    from jupyter_rfb import RemoteFrameBuffer
    from rendercanvas.jupyter import RenderCanvas

    for hook in ("_rc_present_bitmap", "_rc_close"):
        if not callable(getattr(RenderCanvas, hook, None)):
            raise UpstreamChangedError(f"rendercanvas internals changed: jupyter.RenderCanvas.{hook} not found")
    for hook in ("_rfb_send_frame", "_rfb_schedule_lossless_draw", "_rfb_cancel_lossless_draw"):
        if not callable(getattr(RemoteFrameBuffer, hook, None)):
            raise UpstreamChangedError(f"jupyter-rfb internals changed: RemoteFrameBuffer.{hook} not found")
    if not isinstance(RemoteFrameBuffer.class_traits().get("_frame_feedback"), traitlets.Dict):
        raise UpstreamChangedError("jupyter-rfb internals changed: RemoteFrameBuffer._frame_feedback is not a Dict trait")

    class TimedJupyterCanvas(RenderCanvas):
        #: Called with time.perf_counter() when a frame's pixels arrive; None: nobody listens.
        on_present = None
        #: Called with (kind, seconds) per frame streamed or skipped (see the class docstring); None: nobody.
        on_transport = None
        #: Send a frame whose pixels equal the last one's again (False) or not (True).
        skip_unchanged = True
        #: Frames not encoded or sent because their pixels equalled the last frame's.
        unchanged_frames = 0
        _encoder = None
        _lossless_due = False  # the last frame sent was lossy: the lossless picture is still owed
        _frame_owed = True  # the page may lack the last frame (a new view, a resize, back on screen)
        #: jupyter-rfb's front end, with the typing error corrected (see fixed_rfb_esm), acknowledging
        #: every ACK_EVERY-th frame (throttled_ack_esm).
        _esm = throttled_ack_esm(fixed_rfb_esm(str(RenderCanvas._esm)))
        #: jupyter-rfb's acknowledgement of a shown frame (index, timestamps), set by the page; not echoed.
        _frame_feedback = traitlets.Dict({}).tag(sync=True, echo_update=False)

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.observe(self._owe_frame, names=["_has_visible_views"])  # back on screen: send whatever

        def _owe_frame(self, _change=None):
            self._frame_owed = True

        def frame_owed(self) -> bool:
            """Whether the next frame must be sent whatever its pixels: the page may not show the last
            one (a view was added or resized, e.g. a page reload, or came back on screen)."""
            return self._frame_owed

        def handle_event(self, event):
            if event_type(event) == "resize":
                self._frame_owed = True
            super().handle_event(event)

        def _rc_present_bitmap(self, *, data, format, **kwargs):
            if self.on_present is not None:
                self.on_present(time.perf_counter())
            super()._rc_present_bitmap(data=data, format=format, **kwargs)

        def _rfb_send_frame(self, array, is_lossless_redraw=False):
            if array.size == 0:
                return
            last = self._rfb_last_frame
            if (not is_lossless_redraw and self.skip_unchanged and not self._frame_owed and last is not None
                    and last.shape == array.shape and np.array_equal(last, array)):
                self.unchanged_frames += 1
                self.keep_lossless_due()
                self._report("unchanged", 0.0)
                return
            quality = 100 if is_lossless_redraw else self.quality
            self._frame_owed = False
            self._rfb_frame_index += 1
            index = self._rfb_frame_index
            self._rfb_last_frame = array
            timestamp = time.time()
            if is_lossless_redraw:  # no stats, also not on the confirmation of this frame (as jupyter-rfb)
                self._rfb_last_confirmed_index = index
            else:
                self._rfb_stats["sent_frames"] += 1
                if self._rfb_stats["start_time"] <= 0:
                    self._rfb_stats["start_time"] = timestamp
                    self._rfb_last_confirmed_index = index - 1
            job = (index, array, quality, timestamp)
            try:
                loop = asyncio.get_running_loop()
            except RuntimeError:
                loop = None
            if loop is None:  # no event loop: encode and send now
                self._send_encoded(job, *self._encoded(array, quality))
                return
            if self._encoder is None:
                self._encoder = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="grasswidget-frames")
            self._encoder.submit(self._encode_job, loop, job)

        @staticmethod
        def _encoded(array, quality):
            t0 = time.perf_counter()
            try:
                mimetype, data = encode_frame(array, quality)
            except Exception:  # e.g. a broken Pillow: jupyter-rfb's own encoder (whose error, if any, is shown)
                from jupyter_rfb._utils import array2compressed

                mimetype, data = array2compressed(array, quality)
            return mimetype, data, time.perf_counter() - t0

        def _encode_job(self, loop, job):
            # On the worker thread: encode, then send at once (ipykernel's iopub socket takes messages
            # from any thread), so the frame leaves while the loop renders the next; the bookkeeping
            # that belongs to the loop (the lossless redraw's timer, the reports) goes back to it.
            try:
                mimetype, data, encode_s = self._encoded(job[1], job[2])
            except Exception as err:  # never lose the frame silently: the loop shows the error
                self._in_loop(loop, self._encode_failed, err)
                return
            if self.get_closed():
                return
            send_s = self._send_message(job, mimetype, data)
            self._in_loop(loop, self._after_send, job, mimetype, encode_s, send_s)

        @staticmethod
        def _in_loop(loop, callback, *args):
            try:
                loop.call_soon_threadsafe(callback, *args)
            except RuntimeError:  # the loop closed (the kernel is shutting down)
                pass

        def _encode_failed(self, err):
            with self._output_context:  # shown in the widget's output, as jupyter-rfb shows draw errors
                raise err

        def _send_encoded(self, job, mimetype, data, encode_s):
            # Without an event loop: send and do the bookkeeping here.
            if self.get_closed():
                return
            self._after_send(job, mimetype, encode_s, self._send_message(job, mimetype, data))

        def _send_message(self, job, mimetype, data) -> float:
            # jupyter-rfb's message for a frame (its front end's 'framebufferdata'); returns the seconds it took.
            index, _array, _quality, timestamp = job
            t0 = time.perf_counter()
            self.send(dict(type="framebufferdata", mimetype=mimetype, data_b64=None, index=index,
                           timestamp=timestamp), [data])
            return time.perf_counter() - t0

        def _after_send(self, job, mimetype, encode_s, send_s):
            index, array, quality, _timestamp = job
            if self.get_closed():
                return
            newest = index == self._rfb_frame_index
            if "jpeg" in mimetype:
                self._lossless_due = True
                if newest:  # an older frame's lossless picture must never follow a newer frame
                    self._rfb_schedule_lossless_draw(array)
            elif newest:
                self._lossless_due = False
                self._rfb_cancel_lossless_draw()
            if self._rfb_pending_display is not None and self._rfb_last_resize_event is not None:
                self._rfb_pending_display.update(self)  # the first frame: the cell's snapshot
            if quality < 100:  # a frame of the stream (the lossless redraw is jupyter-rfb's extra)
                self._rfb_stats["img_encoding_sum"] += encode_s
                self._report("encode", encode_s)
                self._report("send", send_s)

        def keep_lossless_due(self):
            """The page's picture is still the last frame sent (a frame was not rendered or not sent
            again): if that frame was lossy, its lossless picture still comes 0.3 s later (jupyter-rfb
            cancels it at every draw request)."""
            if self._lossless_due and not self._rfb_lossless_draw_info and self._rfb_last_frame is not None:
                self._rfb_schedule_lossless_draw(self._rfb_last_frame)

        def _report(self, kind, seconds):
            if self.on_transport is not None:
                self.on_transport(kind, seconds)

        def _rc_close(self):
            # jupyter-rfb 1.0.2 closes the canvas widget alone: its Layout and the Output widget it
            # made for callback errors (with that one's Layout) stayed in ipywidgets' registry, three
            # widgets and their comms for every canvas ever closed.
            output = getattr(self, "_output_context", None)
            parts = [self.layout, output, getattr(output, "layout", None)]
            super()._rc_close()
            for part in parts:
                if part is not None:
                    part.close()
            if self._encoder is not None:
                self._encoder.shutdown(wait=False, cancel_futures=True)
                self._encoder = None

    return TimedJupyterCanvas


class DrawCancelled(Exception):
    """Raised by a draw function that renders nothing this time (rendercanvas 2.7 recognises an
    exception of this name: the draw counts as cancelled, nothing is presented or sent)."""


def cancel_draw():
    """End the current draw function without a frame (see :class:`DrawCancelled`)."""
    raise DrawCancelled()


def observe_view_visibility(canvas, callback):
    """Call ``callback(visible)`` each time jupyter-rfb's front end says whether any view of
    ``canvas`` (a jupyter-rfb ``RemoteFrameBuffer``) is on screen (its ``_has_visible_views``
    trait, set from an IntersectionObserver per view). Returns a function that stops observing."""
    name = "_has_visible_views"
    if not canvas.has_trait(name):
        raise UpstreamChangedError(f"jupyter-rfb internals changed: RemoteFrameBuffer.{name} not found")

    def changed(change):
        callback(bool(change["new"]))

    canvas.observe(changed, names=[name])
    return lambda: canvas.unobserve(changed, names=[name])


def observe_frame_feedback(canvas, callback):
    """Call ``callback(index)`` each time jupyter-rfb's front end acknowledges frames of ``canvas``
    (its ``_frame_feedback`` trait: the index of the newest frame the page has shown). Returns a
    function that stops observing."""
    name = "_frame_feedback"
    if not canvas.has_trait(name):
        raise UpstreamChangedError(f"jupyter-rfb internals changed: RemoteFrameBuffer.{name} not found")

    def changed(change):
        callback(int((change["new"] or {}).get("index", 0)))

    canvas.observe(changed, names=[name])
    return lambda: canvas.unobserve(changed, names=[name])


def set_view_visibility(canvas, visible: bool):
    """Set what jupyter-rfb's front end syncs when a view of ``canvas`` comes on or goes off
    screen (its ``_has_visible_views`` trait), as the page would: for tests and headless runs."""
    name = "_has_visible_views"
    if not canvas.has_trait(name):
        raise UpstreamChangedError(f"jupyter-rfb internals changed: RemoteFrameBuffer.{name} not found")
    canvas.set_trait(name, bool(visible))


def set_frame_feedback(canvas, index: int):
    """Acknowledge frame ``index`` of ``canvas`` as jupyter-rfb's front end does when the page showed it
    (its ``_frame_feedback`` trait: index, the frame's timestamp, the page's time): for tests and headless
    runs."""
    import time

    name = "_frame_feedback"
    if not canvas.has_trait(name):
        raise UpstreamChangedError(f"jupyter-rfb internals changed: RemoteFrameBuffer.{name} not found")
    canvas.set_trait(name, {"index": int(index), "timestamp": time.time(), "localtime": time.time()})


#: jupyter-rfb 1.0.2's renderview.js, in the 'input' listener of its hidden key input: the
#: element is ``this._focusElement``; ``this.focus_el`` (its name in jupyter-rfb 0.x) is never set.
RFB_INPUT_BUG = "this.focus_el.value = ''"
RFB_INPUT_FIX = "this._focusElement.value = ''"

#: jupyter-rfb 1.0's front end acknowledges each frame as it shows it (these lines of renderview.js's
#: ``_animate``).
RFB_ACK_EACH_FRAME = "    this._lastFrame = frame\n    this._send_response()\n"
#: The throttled front end acknowledges every ACK_EVERY-th frame (by index) at once ...
ACK_EVERY = 3
#: ... and any other frame ACK_DELAY_MS milliseconds after it was shown unless a later one was acknowledged
#: first (the last frame of a stream, the lossless picture after it, a frame shown alone).
ACK_DELAY_MS = 50


def throttled_ack_esm(esm: str, every: int = ACK_EVERY, delay_ms: int = ACK_DELAY_MS) -> str:
    """jupyter-rfb's front-end module acknowledging fewer frames (:data:`RFB_ACK_EACH_FRAME` replaced).

    Each acknowledgement is a widget message the page sends, the kernel handles and the page then
    sees the kernel go busy and idle for (two status messages, each updating JupyterLab's kernel
    indicators): on a 2-core machine that shares the kernel's cores with the browser, a fixed cost per
    frame shown. Here the page acknowledges frame ``i`` at once when ``i % every == 0``, and otherwise
    ``delay_ms`` ms later unless another acknowledgement went first; an acknowledgement names the
    newest frame shown, so every frame is acknowledged, no later than ``delay_ms``. The kernel's limit
    of frames in flight (``max_buffered_frames``, :data:`grasswidget.views.kernel.MAX_BUFFERED_FRAMES`)
    must leave room for ``every`` frames between two acknowledgements. ``every`` 1: unchanged.
    A module without the expected lines raises :class:`UpstreamChangedError` (check the upgrade)."""
    if not isinstance(every, int) or isinstance(every, bool) or every < 1:
        raise GrassValueError(f"every must be an integer >= 1 (frames per acknowledgement); got {every!r}")
    if not isinstance(delay_ms, int) or isinstance(delay_ms, bool) or not 0 <= delay_ms <= 1000:
        raise GrassValueError(f"delay_ms must be an integer in 0..1000 (milliseconds); got {delay_ms!r}")
    if esm.count(RFB_ACK_EACH_FRAME) != 1:
        raise UpstreamChangedError("jupyter-rfb's renderview.js changed: it no longer acknowledges each frame "
                                   "as grasswidget.compat.throttled_ack_esm expects")
    if every == 1:
        return esm
    throttled = (
        "    this._lastFrame = frame\n"
        "    // grasswidget (compat.throttled_ack_esm): every few frames at once, any other one a little later\n"
        "    clearTimeout(this._gwAckTimer)\n"
        f"    if (frame.index % {every} === 0) {{ this._send_response() }} else {{\n"
        "      this._gwAckTimer = setTimeout(() => { try { this._send_response() } catch { } }, "
        f"{delay_ms})\n"
        "    }\n"
    )
    return esm.replace(RFB_ACK_EACH_FRAME, throttled, 1)


def fixed_rfb_esm(esm: str) -> str:
    """jupyter-rfb's front-end module with its typing error corrected.

    The view moves keyboard focus to a hidden text input on pointer down; each
    character typed there fires 'input', whose listener (jupyter-rfb 1.0.2) clears the
    input with ``this.focus_el.value = ''``. ``focus_el`` is undefined, so every
    character threw ``TypeError: Cannot set properties of undefined (setting
    'value')`` into the page (one per character: the "page error" of a shift + drag
    during which a key was hit), the listener stopped before sending the 'char' event,
    and the hidden input kept every character. The fix names the element the listener
    is registered on (:data:`RFB_INPUT_FIX`). A jupyter-rfb without the faulty line
    (fixed upstream) is returned unchanged; one with a different use of ``focus_el``
    raises :class:`UpstreamChangedError` so the upgrade is checked here."""
    if RFB_INPUT_BUG in esm:
        esm = esm.replace(RFB_INPUT_BUG, RFB_INPUT_FIX)
    if "focus_el" in esm:
        raise UpstreamChangedError("jupyter-rfb's renderview.js changed: it uses focus_el other than as "
                                   "grasswidget.compat.fixed_rfb_esm expects")
    return esm


# ------------------------------------------------------------------ ipywidgets


def widget_registry() -> dict:
    """ipywidgets' registry of open widgets, {model_id: widget} (ipywidgets 8.1:
    ``ipywidgets.widgets.widget._instances``; the public ``Widget.widgets`` that
    returns it is deprecated). An empty dict when this ipywidgets has none."""
    from ipywidgets.widgets import widget

    registry = getattr(widget, "_instances", None)
    return registry if isinstance(registry, dict) else {}


def marimo_anywidget_element(widget):
    """marimo's element of an anywidget (``mo.ui.anywidget(widget)``) and its markup, also where no
    cell runs: ``(element, html)``.

    marimo 0.25 registers a UI element with the running cell and asserts that one runs, so in a
    widget message's handler (a browser without WebGPU: the kernel engine's view is made there)
    ``mo.ui.anywidget`` raises AssertionError. Its runtime context is per thread: a helper thread,
    which has none, makes the element as marimo does outside a notebook, with a random id and
    registered nowhere. The page draws it all the same: the anywidget syncs through its own comm.
    """
    import threading

    import marimo as mo

    try:
        element = mo.ui.anywidget(widget)
        return element, element.text
    except AssertionError:  # no cell runs
        pass
    made = {}

    def make():
        try:
            element = mo.ui.anywidget(widget)
            made["element"], made["html"] = element, element.text
        except BaseException as err:  # handed to the caller below
            made["error"] = err

    helper = threading.Thread(target=make, name="grasswidget-marimo-element", daemon=True)
    helper.start()
    helper.join()
    if "error" in made:
        raise made["error"]
    return made["element"], made["html"]
