"""Every private or internal API grasswidget uses (grasswidget/compat.py) still
exists and behaves as it did in the versions it was checked against. An upgrade
that changes one fails here, by name."""

import types

import numpy as np
import pytest

from grasswidget import compat


def test_every_use_is_listed_with_a_checked_version():
    packages = {p for p, _, _ in compat.PRIVATE_USES}
    assert packages == set(compat.CHECKED)
    installed = compat.installed_versions()
    for name, checked in compat.CHECKED.items():
        have = installed[name]
        assert have is not None, f"{name} is not installed"
        # Same minor version as checked (pyproject pins the range); a new minor must be re-checked here.
        assert have.split(".")[:2] == checked.split(".")[:2], (
            f"{name} {have} is installed; grasswidget.compat was checked against {checked}: "
            "re-check every use of it in compat.PRIVATE_USES, then update CHECKED")


def test_pygfx_buffer_internals():
    import pygfx as gfx
    import wgpu

    from grasswidget.gpu.adapter import ensure_device

    device = ensure_device()  # grasswidget configures pygfx's device first
    buf = gfx.Buffer(np.arange(8, dtype=np.float32), usage=wgpu.BufferUsage.COPY_SRC)
    assert compat.gpu_buffer(buf) is None                      # no GPU object before a sync
    wbuf = compat.sync_buffer(buf)
    assert compat.gpu_buffer(buf) is wbuf                      # Buffer._wgpu_object
    got = np.frombuffer(device.queue.read_buffer(wbuf), np.float32)
    assert np.array_equal(got, np.arange(8))                   # update_resource uploaded the data
    buf.data[:] = 0
    buf.update_full()
    from pygfx.resources._base import resource_update_registry

    assert buf in resource_update_registry._syncable           # a pending upload is registered there
    assert compat.forget_pending_upload(buf)
    assert buf not in resource_update_registry._syncable


def test_pygfx_engine_internals():
    import inspect

    from pygfx.renderers.wgpu.engine import pipeline

    from grasswidget.gpu import indirect

    cls = compat.render_pipeline_container_class()
    assert cls is pipeline.RenderPipelineContainer and callable(getattr(cls, "draw", None))
    source = inspect.getsource(pipeline)
    for name in ("self.broken", "self.wgpu_pipeline", "self.wgpu_bind_groups", "renderstate.wgpu_bind_group",
                 "render_pass.draw("):  # what the indirect draw (gpu/indirect.py) relies on
        assert name in source, name
    for name in ("compute_pass.dispatch_workgroups(", 'self.render_info["indices"]'):  # the indirect dispatch's
        assert name in source, name
    indirect.install()
    assert indirect.is_installed() and compat.render_pipeline_container_class() is indirect.IndirectRenderPipelineContainer
    assert compat.compute_pipeline_container_class() is indirect.IndirectComputePipelineContainer
    event_class = compat.pygfx_event_class("pointer_down")
    assert event_class is not None and compat.pygfx_event_class("no_such_event") is None
    ev = event_class(type="pointer_down", **compat.pygfx_event_fields(
        {"type": "pointer_down", "x": 3, "y": 4, "button": 1, "buttons": (1,), "modifiers": (), "timestamp": 12.5}))
    assert (ev.x, ev.y, ev.button, ev.time_stamp) == (3, 4, 1, 12.5)


def test_default_device_check_and_wgpu_internals():
    import wgpu

    from grasswidget.gpu.adapter import ensure_device

    device = ensure_device()
    assert compat.default_device_exists()
    assert callable(getattr(device, "_poll", None))
    buf = device.create_buffer(size=16, usage=wgpu.BufferUsage.MAP_READ | wgpu.BufferUsage.COPY_DST)
    promise = buf.map_async("READ")
    assert isinstance(promise._state, str) and promise._state.startswith(("pending", "fulfilled"))
    promise.sync_wait()
    compat.poll_device(device)
    assert compat.promise_settled(promise) and promise._state == "fulfilled"
    buf.unmap()
    from wgpu.backends.wgpu_native import extras

    assert callable(extras.write_timestamp)


def test_event_formats():
    """Our handlers read both jupyter-rfb formats: current ("type", "ratio") and legacy."""
    current = {"type": "resize", "width": 10, "height": 8, "ratio": 2.0, "timestamp": 1.0}
    legacy = {"event_type": "resize", "width": 10, "height": 8, "pixel_ratio": 2.0, "time_stamp": 1.0}
    for event in (current, legacy):
        assert compat.event_type(event) == "resize" and compat.event_ratio(event) == 2.0
        capped = compat.with_ratio(event, 1.0)
        assert compat.event_ratio(capped) == 1.0 and compat.event_ratio(event) == 2.0


def test_jupyter_event_format_still_legacy_for_rendercanvas():
    """rendercanvas 2.7's Jupyter canvas asks jupyter-rfb for the legacy format (bitmask 1),
    and jupyter-rfb turns a browser message into it. When this changes, our handlers
    keep working (they read both), but pygfx's controllers may not: re-check."""
    from jupyter_rfb import RemoteFrameBuffer
    from rendercanvas.jupyter import RenderCanvas

    assert RenderCanvas._event_compatibility == 1
    assert callable(getattr(RemoteFrameBuffer, "_rfb_handle_msg", None))
    seen = []

    class Probe(RemoteFrameBuffer):
        _event_compatibility = 3

        def handle_event(self, event):
            seen.append(event)

    probe = Probe()
    probe._rfb_handle_msg(probe, {"type": "pointer_down", "x": 1, "y": 2, "buttons": [1], "modifiers": [],
                                  "timestamp": 5.0}, [])
    probe.close()
    event = seen[0]
    assert event["type"] == event["event_type"] == "pointer_down" and event["time_stamp"] == 5.0
    assert compat.event_type(event) == "pointer_down"


@pytest.mark.parametrize("fmt", ["current", "legacy"])
def test_widget_handlers_take_both_event_formats(widget, fmt):
    """A drag sent in either format orbits the camera (EventsWithoutPicking via compat)."""
    widget.canvas.handle_event({"event_type": "resize", "width": 160, "height": 120, "pixel_ratio": 1.0})
    cam = widget.scene.camera
    p0 = np.array(cam.world.position)
    key, stamp = ("type", "timestamp") if fmt == "current" else ("event_type", "time_stamp")
    base = dict(modifiers=(), ntouches=0, touches={}, **{stamp: 0})
    widget.view.events({key: "pointer_down", "x": 80, "y": 60, "button": 1, "buttons": (1,), **base})
    for i in range(1, 11):
        widget.view.events({key: "pointer_move", "x": 80 + 6 * i, "y": 60, "button": 0, "buttons": (1,), **base})
    widget.view.events({key: "pointer_up", "x": 140, "y": 60, "button": 1, "buttons": (), **base})
    for _ in range(60):
        widget.controller.tick()
    assert np.linalg.norm(np.array(cam.world.position) - p0) > 0.05


def test_held_orbit_controller_hooks_every_step():
    """The OrbitController hooks (grasswidget.views.orbit holds the camera with them) still
    see every orbit, zoom and pan step, and what they return is what the camera gets."""
    import pygfx as gfx

    calls = []

    def hold(controller, position, target, state):
        calls.append(tuple(np.round(position, 6)))
        # keep the camera's height: a "floor" at its start
        if position[1] < 2.0:
            p = np.array(position, np.float64)
            p[1] = 2.0
            return p, state["rotation"], np.asarray(target, np.float64)
        return None

    camera = gfx.PerspectiveCamera(45, 1.0)
    camera.local.position = (0, 2, 10)
    controller = compat.held_orbit_controller_class(hold)(camera, target=(0, 2, 0))
    rect = (0, 0, 100, 100)
    controller.rotate((0.3, 0.0), rect)        # azimuth only: inside the floor
    controller.rotate((0.0, -0.4), rect)       # down: held at the floor
    assert camera.local.position[1] == pytest.approx(2.0)
    controller.zoom(0.2, rect)
    controller.pan((5.0, 0.0), rect)
    assert len(calls) == 4


def test_pygfx_hooks_the_teaching_views_override():
    """pygfx calls WorldObject._update_object on every visible object in each render,
    and get_pick_info hands the pick value to the material's _wgpu_get_pick_info."""
    import inspect

    import pygfx as gfx
    from pygfx.renderers.wgpu.engine import renderer

    assert callable(getattr(gfx.WorldObject, "_update_object", None))
    assert "wobject._update_object()" in inspect.getsource(renderer.FlatScene)
    assert callable(getattr(gfx.Material, "_wgpu_get_pick_info", None))
    source = inspect.getsource(renderer.WgpuRenderer.get_pick_info)
    assert "_wgpu_get_pick_info(pick_value)" in source
    assert "pick_value & 1048575" in source  # 20 bits of object id; the blade id is packed above them


def test_ipykernel_parent_ident():
    """browser.kernel_pump hands deferred shell messages back under the running request's
    identity, read through compat.kernel_parent_ident (ipykernel 7.4: Kernel._parent_ident)."""
    from ipykernel.kernelbase import Kernel

    kernel = Kernel()
    kernel._shell_parent_ident.set(b"cell-7")
    assert compat.kernel_parent_ident(kernel, "shell") == b"cell-7"
    assert compat.kernel_parent_ident(kernel, "control") == b""
    assert compat.kernel_parent_ident(object()) == b""  # a kernel without it (ipykernel 6 path)


def test_ipykernel_shell_socket_internals():
    """browser.kernel_pump reads the main shell's socket while a cell waits, dispatches comm
    messages at once and hands the rest back (compat.kernel_shell_socket, kernel_dispatch_comm,
    kernel_requeue_shell): the ipykernel 7.4 names and signatures they call."""
    import inspect

    from ipykernel.kernelbase import Kernel
    from ipykernel.socket_pair import SocketPair
    from ipykernel.subshell_manager import SubshellManager

    assert "concurrent" in inspect.signature(Kernel.dispatch_shell).parameters
    assert inspect.iscoroutinefunction(Kernel.dispatch_shell)
    assert list(inspect.signature(Kernel.shell_main).parameters)[1:3] == ["subshell_id", "msg"]
    assert callable(getattr(SubshellManager, "get_shell_channel_to_subshell_pair", None))
    assert "to_socket" in inspect.get_annotations(SocketPair)
    assert "shell_channel_thread" in Kernel.class_traits() and "shell_stream" in Kernel.class_traits()
    assert not hasattr(Kernel, "do_one_iteration")  # ipykernel 6 had it (the jupyter-ui-poll path)

    class FakeThread:  # what compat reads of the shell channel thread, and nothing more
        class manager:
            @staticmethod
            def get_shell_channel_to_subshell_pair(subshell_id):
                assert subshell_id is None  # the main shell
                return types.SimpleNamespace(to_socket="main-shell-socket")

    calls = []
    kernel = types.SimpleNamespace(
        shell_channel_thread=FakeThread(), dispatch_shell=lambda frames, concurrent: calls.append((frames, concurrent)),
        io_loop=types.SimpleNamespace(add_callback=lambda *a: calls.append(a)), shell_main="shell_main")
    assert compat.kernel_has_shell_socket(kernel) and compat.kernel_shell_socket(kernel) == "main-shell-socket"
    compat.kernel_dispatch_comm(kernel, ["f"])
    compat.kernel_requeue_shell(kernel, ["g"])
    assert calls == [(["f"], True), ("shell_main", None, ["g"])]
    old_style = types.SimpleNamespace(shell_channel_thread=None, do_one_iteration=lambda: None)
    assert not compat.kernel_has_shell_socket(old_style)


def test_rendercanvas_present_hook_times_each_frame():
    """rendercanvas 2.7's Jupyter canvas hands every rendered frame to _rc_present_bitmap,
    which sends it; compat.timed_jupyter_canvas_class reports the arrival first."""
    from rendercanvas.jupyter import RenderCanvas

    cls = compat.timed_jupyter_canvas_class()
    assert issubclass(cls, RenderCanvas) and callable(getattr(RenderCanvas, "_rc_present_bitmap", None))
    canvas = cls(size=(8, 6))
    seen = []
    canvas.on_present = seen.append
    sent = []
    canvas.send_frame = sent.append  # jupyter-rfb's public method, called by the present hook
    frame = np.zeros((6, 8, 4), np.uint8)
    canvas._rc_present_bitmap(data=frame, format="rgba-u8")
    assert len(seen) == 1 and isinstance(seen[0], float) and len(sent) == 1 and sent[0].shape == (6, 8, 4)
    canvas.close()


def test_closed_jupyter_canvas_leaves_no_widget_open():
    """jupyter-rfb 1.0.2 closes the canvas widget alone; the timed canvas's _rc_close also closes
    its Layout and the output widget jupyter-rfb made for it (RemoteFrameBuffer._output_context)."""
    cls = compat.timed_jupyter_canvas_class()
    registry = compat.widget_registry()
    before = set(registry)
    canvas = cls(size=(8, 6))
    output = canvas._output_context
    made = set(registry) - before
    assert {canvas.model_id, canvas.layout.model_id, output.model_id, output.layout.model_id} <= made
    canvas.close()
    assert set(registry) - before == set()
    assert canvas.get_closed()


def test_pygfx_render_states_outlive_their_renderer():
    """pygfx 0.17 keeps a render state (renderstate._renderstate_instance_cache, a weak dict)
    only while a renderer uses it; keep_renderstates keeps them, so the next renderer finds the
    same state, and with it every cached pipeline. (Two point lights and a spot light: a state
    no GrassScene makes, so no other test has kept it.)"""
    import gc
    import weakref

    import pygfx as gfx
    from pygfx.renderers.wgpu.engine import renderstate
    from rendercanvas.offscreen import RenderCanvas

    def draw_once(keep):
        canvas = RenderCanvas(size=(16, 12), pixel_ratio=1)
        renderer = gfx.WgpuRenderer(canvas)
        scene = gfx.Scene()
        scene.add(gfx.PointLight(), gfx.PointLight(), gfx.SpotLight(),
                  gfx.Mesh(gfx.box_geometry(), gfx.MeshPhongMaterial()))
        camera = gfx.PerspectiveCamera(50)
        camera.show_object(scene)
        canvas.request_draw(lambda: renderer.render(scene, camera))
        canvas.draw()
        states = {key: weakref.ref(state) for key, state in renderstate._renderstate_instance_cache.items()
                  if key and isinstance(key[0], tuple) and key[0][0] == 2}  # the combined state of 2 point lights
        if keep:
            assert compat.keep_renderstates() >= len(states)
        canvas.close()
        return states

    states = draw_once(keep=True)
    assert len(states) == 1
    gc.collect()
    again = draw_once(keep=False)
    for key, state in states.items():  # the same object, not a new one of the same hash
        assert state() is not None and again[key]() is state()


def test_ipywidgets_registry_holds_open_widgets():
    """cell_rerun does not count ipywidgets' registry of open widgets as a holder
    (ipywidgets 8.1: widgets.widget._instances, model id -> widget)."""
    import ipywidgets as ipw

    label = ipw.Label("x")
    registry = compat.widget_registry()
    model_id = label.model_id
    assert registry[model_id] is label
    label.close()
    assert model_id not in compat.widget_registry()


def test_renderer_depth_texture():
    """The occlusion culling copies pygfx's depth buffer: a depth32float texture of the
    render's physical size that can be copied from, 1.0 (far) where nothing is drawn."""
    import numpy as np
    import pygfx as gfx
    import wgpu

    from grasswidget.gpu.adapter import ensure_device

    device = ensure_device()
    target = gfx.Texture(dim=2, size=(40, 30, 1), format="rgba8unorm")
    renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="none", enable_events=False)
    assert compat.renderer_depth_texture(renderer) is None  # nothing rendered yet
    scene = gfx.Scene()
    square = gfx.Mesh(gfx.plane_geometry(1, 1), gfx.MeshBasicMaterial())
    square.local.position = (0, 0, -5)  # a small square in the middle of the view
    scene.add(square)
    renderer.render(scene, gfx.PerspectiveCamera(45))
    depth = compat.renderer_depth_texture(renderer)
    assert depth.format == wgpu.TextureFormat.depth32float and tuple(depth.size[:2]) == (40, 30)
    assert depth.usage & wgpu.TextureUsage.COPY_SRC
    buf = device.create_buffer(size=256 * 30, usage=wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.COPY_SRC)
    enc = device.create_command_encoder()
    enc.copy_texture_to_buffer({"texture": depth, "aspect": "depth-only"},
                               {"buffer": buf, "bytes_per_row": 256, "rows_per_image": 30}, (40, 30, 1))
    device.queue.submit([enc.finish()])
    values = np.frombuffer(device.queue.read_buffer(buf), np.float32).reshape(30, 64)[:, :40]
    assert values[0, 0] == 1.0 and values[-1, -1] == 1.0  # cleared to far where nothing is
    assert 0.0 < values[15, 20] < 1.0  # the square's depth in the middle


def test_jupyter_rfb_front_end_gets_its_typing_error_corrected():
    """jupyter-rfb 1.0.2's renderview.js clears its hidden key input through an undefined
    ``this.focus_el`` (a page error per typed character, tests/e2e
    shows it in Chromium); the kernel canvas ships the corrected module."""
    from jupyter_rfb import RemoteFrameBuffer

    original = str(RemoteFrameBuffer._esm)
    cls = compat.timed_jupyter_canvas_class()
    fixed = str(cls._esm)
    assert "focus_el" not in fixed and compat.RFB_INPUT_FIX in fixed
    expected = compat.throttled_ack_esm(original)  # and its acknowledgements throttled (below)
    if compat.RFB_INPUT_BUG in original:  # only that line differs
        assert fixed == expected.replace(compat.RFB_INPUT_BUG, compat.RFB_INPUT_FIX)
    else:
        assert fixed == expected
    with pytest.raises(compat.UpstreamChangedError):
        compat.fixed_rfb_esm("this.focus_el.focus()")


def test_jupyter_rfb_reports_whether_a_view_is_on_screen():
    from jupyter_rfb import RemoteFrameBuffer

    rfb = RemoteFrameBuffer()
    seen = []
    stop = compat.observe_view_visibility(rfb, seen.append)
    # What jupyter-rfb's front end syncs from its IntersectionObserver (the trait it draws by).
    rfb.set_trait("_has_visible_views", True)
    rfb.set_trait("_has_visible_views", False)
    compat.set_view_visibility(rfb, True)  # the same trait, as tests set it
    stop()
    rfb.set_trait("_has_visible_views", True)
    assert seen == [True, False, True]
    acks = []
    stop = compat.observe_frame_feedback(rfb, acks.append)
    # What its front end syncs when frames arrive (the newest index shown, and when it was sent).
    rfb.set_trait("_frame_feedback", {"index": 3, "timestamp": 1.0, "localtime": 1.1})
    stop()
    rfb.set_trait("_frame_feedback", {"index": 4, "timestamp": 1.2, "localtime": 1.3})
    assert acks == [3]
    rfb.close()


def test_marimo_context_is_per_thread():
    """compat.marimo_anywidget_element makes marimo's element of a widget in a helper thread where no
    cell runs: that thread must see no marimo runtime context."""
    import threading

    pytest.importorskip("marimo")
    from marimo._runtime.context import types as context_types

    assert isinstance(context_types._THREAD_LOCAL_CONTEXT, threading.local)
    from grasswidget.browser.trace_chart import TraceChart

    chart = TraceChart()
    try:
        element, html = compat.marimo_anywidget_element(chart)
        assert html.startswith("<marimo-ui-element") and chart.model_id in html
    finally:
        chart.close()


def test_the_sun_is_reaimed_only_when_it_moves():
    """compat.still_directional_light_class: lights like pygfx's DirectionalLight (same direction
    and pose after every update) but redoes the look_at only after it, its target or its camera moved."""
    import numpy as np
    import pygfx as gfx

    Light = compat.still_directional_light_class()
    still, plain = Light(intensity=2.0), gfx.DirectionalLight(intensity=2.0)
    scene = gfx.Scene()
    for light in (still, plain):
        light.local.position = (0.3, 1.0, 0.2)
        scene.add(light)

    def update_both():
        for light in (still, plain):
            light._gfx_update_uniform_buffer()
        assert np.allclose(still.uniform_buffer.data["direction"], plain.uniform_buffer.data["direction"])
        assert np.allclose(still.world.matrix, plain.world.matrix, atol=1e-6)

    update_both()
    stamp = still.world.last_modified
    update_both()
    assert still.world.last_modified == stamp  # standing still: no look_at, nothing marked changed
    assert plain.world.last_modified != stamp
    for light in (still, plain):  # the light moves: re-aimed
        light.local.position = (-1.0, 0.5, 0.0)
    update_both()
    assert still.world.last_modified != stamp
    for light in (still, plain):  # its target moves: re-aimed
        light.target.local.position = (0.0, -2.0, 1.0)
    update_both()
    camera = gfx.PerspectiveCamera(45)
    for light in (still, plain):  # on a camera it follows the camera
        camera.add(light)
    update_both()
    camera.local.position = (0.0, 2.0, 3.0)
    camera.look_at((1.0, 0.0, 0.0))
    update_both()


def test_render_targets_of_a_renderstate_and_a_pass_on_them():
    """compat.render_target_formats names the formats of the pass pygfx draws a renderstate's
    objects into (a render bundle recorded for them runs in that pass), and
    compat.begin_target_render_pass opens a pass on the same targets, loading what was drawn."""
    import numpy as np
    import pygfx as gfx

    from grasswidget.gpu.adapter import ensure_device

    device = ensure_device()
    target = gfx.Texture(dim=2, size=(40, 30, 1), format="rgba8unorm")
    renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="none", enable_events=False)
    scene = gfx.Scene()
    square = gfx.Mesh(gfx.plane_geometry(1, 1), gfx.MeshBasicMaterial(color="#ff0000"))
    square.local.position = (0, 0, -5)
    scene.add(square)
    renderer.render(scene, gfx.PerspectiveCamera(45), flush=False)
    renderstate = renderer._renderstates_per_flush[0][-1]
    colors, depth = compat.render_target_formats(renderstate)
    assert colors[0] == renderer._blender.get_texture("color").format and depth == "depth32float"
    bundle = device.create_render_bundle_encoder(color_formats=list(colors), depth_stencil_format=depth).finish()
    encoder = device.create_command_encoder()
    render_pass = compat.begin_target_render_pass(renderer, encoder, "opaque")
    render_pass.execute_bundles([bundle])  # an incompatible bundle is a validation error
    render_pass.end()
    device.queue.submit([encoder.finish()])
    renderer.flush()
    img = np.asarray(target.data if target.data is not None else renderer.snapshot())
    red = (img[..., 0] > 150) & (img[..., 1] < 80)
    assert 0.0 < red.mean() < 0.5  # loaded, not cleared: the square is still there


def test_pygfx_ddaa_shader_templated_as_its_pass_templates_it():
    """compat.ddaa_fragment_wgsl: pygfx's ddaa2.wgsl for a DDAAPass's settings, with the fragment
    entry point gpu/compute_ddaa.py turns into a function (the edge search unrolled per step)."""
    from pygfx.renderers.wgpu import DDAAPass

    short, long = (compat.ddaa_fragment_wgsl(DDAAPass(max_edge_iters=n)) for n in (1, 5))
    for code in (short, long):
        assert code.count(compat.DDAA_FRAGMENT_HEAD) == 1 and "textureSampleLevel(tex, smp" in code
    assert "const MAX_EDGE_ITERS = 1;" in short and "const MAX_EDGE_ITERS = 5;" in long
    assert len(long) > len(short)


def test_output_pass_is_a_texture_copy_only_where_it_copies_exactly():
    """pygfx's output pass (a full-screen pass from the colour target into the canvas) is replaced by a
    texture copy where it is one: same format and size, gamma 1, opaque. The picture is the pass's byte for
    byte (a translucent ball blended over grass and sky included); where it is not a copy (supersampled
    export, an rgba8unorm texture) the pass runs."""
    import pygfx as gfx

    import grasswidget as gw
    from grasswidget.gpu.scene import GrassScene, make_renderer

    scene = GrassScene(gw.Blades.on_plane(512, seed=0), size=(80, 60))
    scene.colliders = [gw.SphereCollider(center=(0, 0.5, 0), radius=1.5)]
    scene.field.step(2)
    renderer = scene.renderer
    assert renderer.opaque_output and renderer.output_copies == 0
    copied = scene.render().copy()
    assert renderer.output_copies == 1
    renderer.opaque_output = False  # the pass
    drawn = scene.render().copy()
    assert renderer.output_copies == 1
    renderer.opaque_output = True
    assert copied.shape == (60, 80, 4) and np.array_equal(copied, drawn)
    scene.show_colliders = False
    no_ball = scene.render()
    assert renderer.output_copies == 2
    assert (np.abs(no_ball.astype(int) - copied).max(axis=-1) > 8).sum() > 50  # the ball is in the picture
    # Not a copy: supersampled (the colour target is larger than the canvas), an rgba8unorm texture.
    export = make_renderer(gfx.Texture(dim=2, size=(80, 60, 1), format="rgba8unorm-srgb", colorspace="tex-srgb"), export=True)
    linear = make_renderer(gfx.Texture(dim=2, size=(80, 60, 1), format="rgba8unorm"))
    for other in (export, linear):
        scene.draw_into(other)
        assert other.output_copies == 0
    same = make_renderer(gfx.Texture(dim=2, size=(80, 60, 1), format="rgba8unorm-srgb", colorspace="tex-srgb"))
    scene.draw_into(same)
    assert same.output_copies == 1


def _frame(h=24, w=32, seed=0):
    """A smooth RGBA picture (JPEG keeps it within a few levels) that differs by seed."""
    y, x = np.mgrid[0:h, 0:w]
    rgb = np.stack([x * 3 + seed * 20, y * 4, np.full_like(x, 90 + seed)], axis=2)  # no edges, < 256
    return np.concatenate([rgb, np.full((h, w, 1), 255)], axis=2).astype(np.uint8)


def _decoded(data):
    import io

    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(bytes(data))).convert("RGB")).astype(int)


class _Sent(list):
    """The messages a jupyter-rfb canvas sends, with the thread each was sent on."""

    def __call__(self, msg, buffers=None):
        import threading

        self.append((msg, list(buffers or []), threading.current_thread().name))


def _on_a_thread_of_its_own(test):
    """Run ``test`` on a new thread: the canvas's transport depends on whether an asyncio loop runs
    on the calling thread, and a process of the suite may have one running on its main thread (a
    sync Playwright session of tests/e2e, kept for the session on the same xdist worker)."""
    import functools
    import threading

    @functools.wraps(test)
    def run(*args, **kwargs):
        failure = []

        def body():
            try:
                test(*args, **kwargs)
            except BaseException as err:  # re-raised on the test's thread
                failure.append(err)

        thread = threading.Thread(target=body, name=f"test-{test.__name__}")
        thread.start()
        thread.join(120.0)
        assert not thread.is_alive(), f"{test.__name__} did not end in 120 s"
        if failure:
            raise failure[0]

    return run


@_on_a_thread_of_its_own
def test_jupyter_canvas_sends_a_frame_once_and_its_pixels():
    """Without an event loop (a script) a frame is encoded and sent at once, as jupyter-rfb's
    message; the same pixels again are not encoded or sent; other pixels are."""
    canvas = compat.timed_jupyter_canvas_class()(size=(32, 24))
    sent = canvas.send = _Sent()
    seen = []
    canvas.on_transport = lambda kind, s: seen.append((kind, s))
    try:
        a, b = _frame(seed=0), _frame(seed=1)
        canvas.send_frame(a)
        canvas.send_frame(a.copy())  # equal pixels: not sent again
        canvas.send_frame(b)
        assert [m["index"] for m, _, _ in sent] == [1, 2] and canvas.unchanged_frames == 1
        for (msg, bufs, _), frame in zip(sent, (a, b)):
            assert msg["type"] == "framebufferdata" and msg["mimetype"] == "image/jpeg" and len(bufs) == 1
            assert np.abs(_decoded(bufs[0]) - frame[:, :, :3]).mean() < 6.0  # the picture, lossy
        assert [k for k, _ in seen] == ["encode", "send", "unchanged", "encode", "send"]
        assert all(s >= 0.0 for _, s in seen)
        assert canvas.get_stats()["sent_frames"] == 2  # jupyter-rfb's own count, as it keeps it
        # the page may lack the last frame: a resize (a new view, a page reload) or a view back on screen
        canvas.handle_event({"event_type": "resize", "width": 32, "height": 24, "pixel_ratio": 1.0})
        assert canvas.frame_owed()
        canvas.send_frame(b.copy())
        canvas.send_frame(b.copy())
        compat.set_view_visibility(canvas, True)
        canvas.send_frame(b.copy())
        assert [m["index"] for m, _, _ in sent] == [1, 2, 3, 4] and canvas.unchanged_frames == 2
        assert not canvas.frame_owed()
        canvas.skip_unchanged = False
        canvas.send_frame(b.copy())
        assert len(sent) == 5
    finally:
        canvas.close()


@_on_a_thread_of_its_own
def test_jupyter_canvas_encodes_on_a_worker_in_order_and_still_sends_the_lossless_picture(monkeypatch):
    """With the event loop running, frames are encoded and sent on one worker thread, in order (not
    waiting for the loop, which renders the next frame meanwhile); 0.3 s after the last lossy frame
    the lossless PNG of its exact pixels follows, also when that frame's pixels came again meanwhile."""
    import asyncio
    import threading

    encoders = []
    encode = compat.encode_frame

    def recording_encode(array, quality):
        encoders.append(threading.current_thread().name)
        return encode(array, quality)

    monkeypatch.setattr(compat, "encode_frame", recording_encode)
    canvas = compat.timed_jupyter_canvas_class()(size=(32, 24))
    sent = canvas.send = _Sent()
    reports = []
    canvas.on_transport = lambda kind, s: reports.append((kind, threading.current_thread().name))
    frames = [_frame(seed=i) for i in range(4)]

    async def run():
        for f in frames:
            canvas.send_frame(f)
        canvas.send_frame(frames[-1].copy())  # unchanged
        deadline = asyncio.get_running_loop().time() + 10.0
        while not any(m["mimetype"] == "image/png" for m, _, _ in sent):
            assert asyncio.get_running_loop().time() < deadline, f"no lossless frame: {[m for m, _, _ in sent]}"
            await asyncio.sleep(0.02)

    try:
        asyncio.run(run())
        lossy = [(m, b, t) for m, b, t in sent if m["mimetype"] == "image/jpeg"]
        assert [m["index"] for m, _, _ in lossy] == [1, 2, 3, 4] and canvas.unchanged_frames == 1
        assert encoders and all(name.startswith("grasswidget-frames") for name in encoders)
        assert all(t.startswith("grasswidget-frames") for _, _, t in sent)  # sent by the worker too
        png = [(m, b) for m, b, _ in sent if m["mimetype"] == "image/png"]
        assert len(png) == 1 and png[0][0]["index"] == 5
        assert sorted(k for k, _ in reports) == ["encode"] * 4 + ["send"] * 4 + ["unchanged"]
        assert {t for _, t in reports} == {threading.current_thread().name}  # reported on the loop's thread
        assert np.array_equal(_decoded(png[0][1][0]), frames[-1][:, :, :3])  # exact
    finally:
        canvas.close()


def test_encode_frame_jpeg_and_png():
    frame = _frame(48, 64, seed=2)
    mimetype, data = compat.encode_frame(frame, 70)
    assert mimetype == "image/jpeg" and np.abs(_decoded(data) - frame[:, :, :3]).mean() < 6.0
    mimetype, data = compat.encode_frame(frame[:, :, :3], 100)
    assert mimetype == "image/png" and np.array_equal(_decoded(data), frame[:, :, :3])


@_on_a_thread_of_its_own
def test_jupyter_canvas_falls_back_to_jupyter_rfbs_encoder(monkeypatch):
    """A failing encoder (e.g. a broken Pillow) does not stop the stream: the frame goes out through
    jupyter-rfb's own encoder."""
    def broken(array, quality):
        raise OSError("encoder broken")

    monkeypatch.setattr(compat, "encode_frame", broken)
    canvas = compat.timed_jupyter_canvas_class()(size=(32, 24))
    sent = canvas.send = _Sent()
    try:
        frame = _frame(seed=3)
        canvas.send_frame(frame)
        assert len(sent) == 1 and sent[0][0]["mimetype"] in ("image/jpeg", "image/png")
        assert np.abs(_decoded(sent[0][1][0]) - frame[:, :, :3]).mean() < 6.0
    finally:
        canvas.close()


def test_jupyter_canvas_does_not_echo_the_frame_acknowledgement():
    """The page acknowledges every frame through jupyter-rfb's ``_frame_feedback``; ipywidgets 8
    echoes a trait the page sets back to the page: not this one (a message per frame no view reads).
    Other traits the page sets are still echoed, and the acknowledgement still reaches the kernel."""
    canvas = compat.timed_jupyter_canvas_class()(size=(32, 24))
    sent = []
    canvas._send = lambda msg, buffers=None: sent.append(msg)  # the comm's send, below the echo
    arrived = []
    stop = compat.observe_frame_feedback(canvas, arrived.append)
    try:
        def update(state):
            canvas._handle_msg({"content": {"data": {"method": "update", "state": state, "buffer_paths": []}},
                                "buffers": []})

        update({"_frame_feedback": {"index": 3, "timestamp": 1.0, "localtime": 2.0}})
        assert arrived == [3] and not [m for m in sent if m.get("method") == "echo_update"]
        update({"_has_visible_views": True})
        assert [m["state"] for m in sent if m.get("method") == "echo_update"] == [{"_has_visible_views": True}]
    finally:
        stop()
        canvas.close()


def test_jupyter_rfb_front_end_acknowledges_every_few_frames():
    """The kernel canvas's front end acknowledges every ACK_EVERY-th frame at once and any other after
    ACK_DELAY_MS unless a later acknowledgement went first; the kernel leaves room for the frames
    between two acknowledgements. Its _animate is run here on a stand-in page (node), frames 1..7:
    the acknowledgements are of the frames whose index ACK_EVERY divides, at once, then of frame 7
    (the newest) after the delay."""
    import json
    import shutil
    import subprocess

    from jupyter_rfb import RemoteFrameBuffer

    from grasswidget.views.kernel import MAX_BUFFERED_FRAMES

    original = str(RemoteFrameBuffer._esm)
    throttled = compat.throttled_ack_esm(original)
    assert throttled != original and compat.RFB_ACK_EACH_FRAME not in throttled
    assert compat.throttled_ack_esm(original, every=1) == original
    assert MAX_BUFFERED_FRAMES >= compat.ACK_EVERY + 1
    for bad in (dict(every=0), dict(every=1.5), dict(delay_ms=-1), dict(delay_ms=5000)):
        with pytest.raises(compat.GrassValueError):
            compat.throttled_ack_esm(original, **bad)
    with pytest.raises(compat.UpstreamChangedError):
        compat.throttled_ack_esm("this._send_response()")
    node = shutil.which("node")
    if node is None:
        pytest.skip("no node here to run the front end's acknowledgement")
    start = throttled.index("  _animate () {")
    body = throttled[start:throttled.index("\n  }\n", start) + 4]
    script = (
        "const acks = []; const t0 = Date.now();\n"
        "globalThis.window = { requestAnimationFrame: () => 0 };\n"
        "globalThis.URL = { createObjectURL: () => 'blob:x', revokeObjectURL: () => {} };\n"
        "class Page {\n" + body + "\n"
        "  _send_response () { acks.push([this._lastFrame.index, Date.now() - t0]) }\n"
        "}\n"
        "const page = Object.assign(new Page(), { _frames: [], views: [], _lastSrc: '' });\n"
        "for (let i = 1; i <= 7; i++) { page._frames.push({ index: i, buffers: [], data_b64: 'x' }); page._animate() }\n"
        "setTimeout(() => console.log(JSON.stringify(acks)), 4 * " + str(compat.ACK_DELAY_MS) + ");\n"
    )
    out = subprocess.run([node, "-e", script], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    acks = json.loads(out.stdout)
    at_once = [i for i in range(1, 8) if i % compat.ACK_EVERY == 0]
    assert 7 not in at_once and [index for index, _ in acks] == at_once + [7]
    assert all(t < compat.ACK_DELAY_MS / 2 for _, t in acks[:-1])  # at once
    assert acks[-1][1] >= compat.ACK_DELAY_MS - 5  # the newest waited
