"""backend="auto" in the kernel (no browser): the default widget, and what the page's adapter
report does to it. The page's side (the probe in a real Chromium) is tested in
tests/e2e/test_engine_auto_browser.py."""

from __future__ import annotations

import html

import numpy as np

import grasswidget as gw
from grasswidget.views.browser import BrowserEngineView
from grasswidget.views.kernel import KernelView

NVIDIA = {"webgpu": True, "adapter": True, "fallback": False, "vendor": "nvidia", "architecture": "ampere",
          "device": "", "description": "", "detail": ""}
SWIFTSHADER = dict(NVIDIA, vendor="google", architecture="swiftshader")


def test_auto_is_the_default_and_runs_the_kernel_until_a_view_reports(tmp_path):
    """On this CPU machine (lavapipe) a default widget streams from the kernel at once, says so,
    and with no view ever shown (a script) stays there: save_png renders in the kernel."""
    w = gw.GrassWidget(64, size=(64, 48))
    try:
        assert w.backend == "kernel" and isinstance(w.view, KernelView)
        assert w.adapter_probe is not None and w.adapter_probe in w.children[0].children
        assert w.engine_reason.startswith("kernel engine: the kernel renders on a CPU adapter (llvmpipe)")
        assert "no view has reported" in w.engine_reason
        assert w.engine_reason in html.unescape(w.panel.message_line.value)
        path = w.save_png(str(tmp_path / "script.png"), size=(64, 48))
        import imageio.v3 as iio

        img = iio.imread(path)
        assert img.shape == (48, 64, 4) and img[..., 1].mean() > 0  # a picture, from the kernel
    finally:
        w.close()
    explicit = gw.GrassWidget(64, size=(64, 48), backend="kernel")
    try:
        assert explicit.adapter_probe is None and explicit.engine_reason is None
    finally:
        explicit.close()


def test_a_hardware_adapter_report_switches_to_the_browser_engine_keeping_the_state_of_the_controls():
    w = gw.GrassWidget(256, size=(64, 48))
    try:
        w.pause()
        w.camera_state = {"position": (1.0, 3.0, 9.0), "target": (0.0, 0.5, 0.0)}
        w.params.wind_strength = 17.0
        w.ball.enabled = True
        w.inspect([3, 5])
        assert w.params.shadows is False  # the kernel's CPU adapter: the sunlight's shadows off
        w.adapter_probe.report = NVIDIA  # what the probe's first view would say on a laptop with a GPU
        assert w.backend == "browser" and isinstance(w.view, BrowserEngineView)
        # the page's GPU draws now: shadows on (core.params.sunlight_defaults), sent to the browser
        from grasswidget.core.uniform_layouts import GRASS_MATERIAL_LAYOUT, offsets

        at = offsets(GRASS_MATERIAL_LAYOUT)["shadows"][0]
        assert w.params.shadows is True
        assert np.frombuffer(w.view.engine_widget.material_uniform[at: at + 4], "<f4")[0] == 1.0
        assert w.engine_reason == ("browser engine: the kernel renders on a CPU adapter (llvmpipe) and this "
                                   "browser offers a GPU (nvidia ampere)")
        assert w.engine_reason in html.unescape(w.panel.message_line.value)
        assert w.children[0].children[0] is w.view.widget  # the browser engine's view in the kernel view's place
        bv = w.view.engine_widget
        assert bv.params is w.params and bv.playing is False
        assert np.allclose(bv.camera["position"], (1, 3, 9)) and np.allclose(bv.camera["target"], (0, 0.5, 0))
        assert list(bv.inspected) == [3, 5] and len(bv.balls) == 1
        # Decided once: a later report changes nothing.
        w.adapter_probe.report = SWIFTSHADER
        assert w.backend == "browser"
    finally:
        w.close()


def test_a_fallback_adapter_report_keeps_the_kernel_engine():
    w = gw.GrassWidget(64, size=(64, 48))
    try:
        view = w.view
        w.adapter_probe.report = SWIFTSHADER
        assert w.backend == "kernel" and w.view is view and w.params.shadows is False
        assert "CPU fallback too (google swiftshader)" in w.engine_reason
        assert w.engine_reason in html.unescape(w.panel.message_line.value)
    finally:
        w.close()


def test_kernel_on_a_gpu_or_with_no_adapter_decides_at_once(monkeypatch):
    """No probe where the page cannot change the choice: a kernel GPU keeps the kernel engine, a kernel
    without an adapter starts the browser engine (the kernel's adapter kind simulated here)."""
    from grasswidget.notebook import engine_auto

    monkeypatch.setattr(engine_auto, "kernel_adapter", lambda: ("gpu", "NVIDIA H100"))
    w = gw.GrassWidget(64, size=(64, 48))
    try:
        assert w.backend == "kernel" and w.adapter_probe is None
        assert w.engine_reason == "kernel engine: the kernel renders on a GPU (NVIDIA H100)"
        assert w.engine_reason in html.unescape(w.panel.message_line.value)
    finally:
        w.close()
    monkeypatch.setattr(engine_auto, "kernel_adapter", lambda: ("none", ""))
    w = gw.GrassWidget(64, size=(64, 48))
    try:
        assert w.backend == "browser" and isinstance(w.view, BrowserEngineView) and w.adapter_probe is None
        assert w.engine_reason.startswith("browser engine: the kernel has no WebGPU adapter")
    finally:
        w.close()


def test_the_sunlights_default_follows_the_adapter_until_the_user_sets_it():
    """notebook/shadows_default.py: an adapter report sets ``shadows`` (a GPU: on, a software
    adapter by name: off) while it is the widget's default; never params the user passed, never
    after the user set it."""
    from grasswidget.notebook.shadows_default import ShadowsDefault, engine_adapter_is_cpu

    assert engine_adapter_is_cpu("google swiftshader Google SwiftShader") and engine_adapter_is_cpu("llvmpipe")
    # as the "auto" rule: an adapter not known as a software one is a GPU
    assert not engine_adapter_is_cpu("nvidia ampere NVIDIA GeForce RTX 4090") and not engine_adapter_is_cpu("")
    params = gw.GrassParams(shadows=False)
    default = ShadowsDefault(params, own=True)
    default.apply_engine_adapter("nvidia ampere")
    assert params.shadows is True
    default.apply_engine_adapter("google swiftshader")
    assert params.shadows is False and default.live
    params.shadows = True  # the user's value: kept from now on
    default.apply(cpu_adapter=True)
    assert params.shadows is True and not default.live
    theirs = gw.GrassParams(shadows=False)
    ShadowsDefault(theirs, own=False).apply(cpu_adapter=False)
    assert theirs.shadows is False

