"""The widget in marimo (``marimo run``), in Chromium with WebGPU (SwiftShader), both engines.

One notebook file, one marimo server, one page: a kernel-engine GrassWidget, a
browser-engine GrassWidget, a probe cell showing what the kernel holds (each widget's
``params.wind_strength`` and ``playing``, written by the kernel as they change) and a
run button whose cell assigns ``w.params.wind_strength = 20.0`` from Python. For each
engine, through the page only, as a marimo user would:

* the view shows grass under a sky (pixels) and the panel's stats line counts frames;
* the picture changes while playing; after the panel's "Pause" the kernel says
  ``playing`` False, the stats line says "paused" and the picture stays; "Play" animates again;
* the wind slider moved with the keyboard in the page reaches ``params`` in the kernel (the probe);
* the later cell's Python assignment moves both wind sliders (their readouts say 20.0).

And in a Chromium without WebGPU (a notebook of its own): a ``backend="browser"`` widget hands
over to the kernel engine in marimo too (the stage shows jupyter-rfb's view with grass, the message
line says why, the stats line counts frames).

And ``backend="auto"`` (the default; a notebook and a server of its own, one page per outcome): with
SwiftShader's fallback adapter the kernel engine stays (frames stream, the message line says why, a
later cell reads ``w.backend == "kernel"``); with a hardware adapter simulated before the page loads
the widget switches to the browser engine in marimo (the stage shows its canvas, which draws grass,
and the later cell reads ``"browser"``).

Screenshots of both widgets go to ``$GW_ARTIFACTS_DIR`` (or a temporary folder, printed).
"""

from __future__ import annotations

import json
import os
import re
import tempfile
import textwrap
from pathlib import Path

import numpy as np
import pytest

from .controls import drag, panel_label
from .polling import poll
from .servers import MarimoServer

pytestmark = [pytest.mark.browser, pytest.mark.slow]
pytest.importorskip("marimo")

N_BLADES = 1024
ENGINES = ("kernel", "browser")

NOTEBOOK = textwrap.dedent(f'''
    import marimo

    app = marimo.App(width="full")


    @app.cell
    def _():
        import html
        import json

        import ipywidgets as ipw
        import marimo as mo

        import grasswidget as gw
        from grasswidget.notebook.control_mirror import ControlMirror
        return ControlMirror, gw, html, ipw, json, mo


    @app.cell
    def _(gw):
        wk = gw.GrassWidget({N_BLADES}, backend="kernel", size=(320, 240))
        wk
        return (wk,)


    @app.cell
    def _(gw):
        wb = gw.GrassWidget({N_BLADES}, backend="browser", size=(320, 240))
        wb
        return (wb,)


    @app.cell
    def _(ControlMirror, html, ipw, json, wb, wk):
        # What the kernel holds, rewritten by the kernel whenever it changes.
        probe = ipw.HTML()

        def show(_change=None):
            state = {{name: {{"wind": w.params.wind_strength, "playing": w.playing, "ball": w.ball.enabled,
                             "chart": w.chart}}
                     for name, w in (("kernel", wk), ("browser", wb))}}
            probe.value = "<code class='kernel-state'>" + html.escape(json.dumps(state)) + "</code>"

        for w in (wk, wb):
            w.params.observe(show, names="wind_strength")
            w.observe(show, names=["playing", "chart"])
            w.ball.observe(show, names="enabled")
        show()
        ControlMirror(probe)
        return


    @app.cell
    def _(mo):
        setter = mo.ui.run_button(label="set the wind from Python")
        setter
        return (setter,)


    @app.cell
    def _(mo, setter, wb, wk):
        mo.stop(not setter.value)
        wk.params.wind_strength = 20.0
        wb.params.wind_strength = 20.0
        return


    if __name__ == "__main__":
        app.run()
''')


def _artifacts() -> Path:
    out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-marimo-"))
    out.mkdir(parents=True, exist_ok=True)
    return out


@pytest.fixture(scope="module")
def marimo_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("marimo")
    (root / "meadows.py").write_text(NOTEBOOK)
    return root


@pytest.fixture(scope="module")
def marimo_page(marimo_root, webgpu_chromium):
    """A tab of the session's WebGPU Chromium on the module's marimo server, closed after the module."""
    browser = webgpu_chromium
    with MarimoServer(marimo_root / "meadows.py") as server:
        page = browser.new_page()
        try:
            page.goto(server.base_url, wait_until="domcontentloaded", timeout=60_000)
            poll(lambda: page.locator(".grasswidget-marimo").count() == 2, "marimo to show both widgets", 120, 0.5,
                 page=page)
            yield page
        except BaseException:
            print("\n[marimo log]\n" + server.log_text(4000) + "\n[console]\n" + "\n".join(browser.console[-40:]))
            raise
        finally:
            page.close()


def _root(page, engine):
    return page.locator(".grasswidget-marimo").nth(ENGINES.index(engine))


def _view(page, engine):
    selector = "img.renderview-view" if engine == "kernel" else "canvas.grasswidget-canvas"
    return _root(page, engine).locator(selector).first


def _pixels(page, engine):
    import imageio.v3 as iio

    loc = _view(page, engine)
    loc.scroll_into_view_if_needed()
    return iio.imread(loc.screenshot(), extension=".png")[..., :3].astype(np.int32)


def _grass_and_sky(px):
    h = px.shape[0]
    low, top = px[int(0.6 * h):], px[: int(0.1 * h)]
    grass = ((low[..., 1] > low[..., 0] + 8) & (low[..., 1] > low[..., 2] + 8)).mean()
    sky = ((top[..., 2] > top[..., 0] + 10) & (top[..., 2] >= top[..., 1])).mean()
    return float(grass), float(sky)


def _kernel_state(page):
    text = page.locator("code.kernel-state").first.inner_text()
    return json.loads(text)


def _status(page, engine):
    # the panel lives in the mirror's shadow root: read the text there (innerText stops at a shadow host)
    return _root(page, engine).locator(".gwm-root").first.inner_text()


def _wind_slider(page, engine):
    label = panel_label("wind_strength")
    return _root(page, engine).locator(".gwm-slider").filter(
        has=page.locator(".gwm-label", has_text=re.compile("^" + re.escape(label) + "$")))


def _button(page, engine, name):
    return _root(page, engine).locator("button.gwm-button:visible", has_text=re.compile(f"^{name}$")).first


def _changes(page, engine, before, what, timeout=60):
    def check():
        now = _pixels(page, engine)
        diff = float(np.abs(now - before).mean())
        return diff > 0.2, diff
    return poll(check, what, timeout, 0.5, page=page)


@pytest.mark.parametrize("engine", ENGINES)
def test_grass_frames_and_play_pause_in_marimo(marimo_page, engine):
    page = marimo_page
    poll(lambda: re.search(r"[\d.]+ frames/s", _status(page, engine)), f"the {engine} engine's stats line to "
         "count frames", 120, 0.5, page=page)
    # grass below, sky above (polled: the page may still be laying out cells while it loads)
    def meadow():
        px = _pixels(page, engine)
        grass, sky = _grass_and_sky(px)
        return grass > 0.3 and sky > 0.5, (grass, sky, px)
    grass, sky, first = poll(meadow, f"the {engine} view to show grass under a sky", 30, 0.5, page=page)
    _root(page, engine).screenshot(path=str(_artifacts() / f"marimo-{engine}.png"))
    print(f"\n[marimo {engine}] grass {grass:.0%} of the lower part, sky {sky:.0%} of the top; "
          f"screenshot in {_artifacts()}")
    _changes(page, engine, first, f"the {engine} engine's picture to change while playing")

    _button(page, engine, "Pause").click()
    poll(lambda: _kernel_state(page)[engine]["playing"] is False, "the kernel to say paused", 30, 0.2, page=page)
    poll(lambda: "paused" in _status(page, engine), "the stats line to say paused", 30, 0.2, page=page)
    _button(page, engine, "Play").wait_for(timeout=10_000)  # the button now offers Play
    # the paused view settles (the kernel engine sends one full-resolution frame after pausing) ...
    seen = [_pixels(page, engine)]

    def settled():
        seen.append(_pixels(page, engine))
        a, b = seen[-2], seen[-1]
        return bool(_grass_and_sky(b)[0] > 0.3 and float(np.abs(a - b).mean()) < 0.2), len(seen)
    poll(settled, f"the paused {engine} view to settle on a picture of grass", 30, 0.3, page=page)
    still = seen[-1]
    page.wait_for_timeout(1500)  # ... and stays: a span of wall time in which a playing meadow would move
    assert float(np.abs(_pixels(page, engine) - still).mean()) < 0.2, "the picture moved while paused"

    _button(page, engine, "Play").click()
    poll(lambda: _kernel_state(page)[engine]["playing"] is True, "the kernel to say playing", 30, 0.2, page=page)
    _changes(page, engine, still, f"the {engine} engine's picture to move again after Play")


def test_sliders_and_python_in_marimo(marimo_page):
    page = marimo_page
    import grasswidget as gw

    top = gw.GrassParams.class_traits()["wind_strength"].hi
    for engine in ENGINES:
        slider = _wind_slider(page, engine)
        slider.locator("input[type=range]").focus()
        page.keyboard.press("End")  # the slider's top, as a user's keyboard puts it there
        poll(lambda: _kernel_state(page)[engine]["wind"] == pytest.approx(top), f"the {engine} widget's "
             f"params.wind_strength to reach {top} in the kernel", 30, 0.2, page=page)
    # the other widget kept its own value: one slider, one widget
    assert _kernel_state(page)["kernel"]["wind"] == pytest.approx(top)

    page.get_by_role("button", name="set the wind from Python").first.click()
    for engine in ENGINES:
        readout = _wind_slider(page, engine).locator(".gwm-readout")
        poll(lambda: readout.inner_text().strip() == "20.0", f"the {engine} wind slider to show 20.0 after "
             "the later cell's assignment", 60, 0.2, page=page)
        assert float(_wind_slider(page, engine).locator("input[type=range]").input_value()) == pytest.approx(20.0)
    assert {e: s["wind"] for e, s in _kernel_state(page).items()} == {"kernel": 20.0, "browser": 20.0}


def _checkbox(page, engine, label):
    return _root(page, engine).locator(".gwm-checkbox", has_text=re.compile(f"^{re.escape(label)}$")) \
        .locator("input").first


@pytest.mark.parametrize("engine", ENGINES)
def test_pointer_save_and_chart_in_marimo(marimo_page, marimo_root, engine):
    page = marimo_page
    if _kernel_state(page)[engine]["playing"]:
        _button(page, engine, "Pause").click()
        poll(lambda: _kernel_state(page)[engine]["playing"] is False, "the kernel to say paused", 30, 0.2, page=page)
    view = _view(page, engine)
    still = _pixels(page, engine)
    drag(page, view, 80, 0)  # orbit
    _changes(page, engine, still, f"a drag to orbit the paused {engine} view", timeout=30)

    assert not _checkbox(page, engine, "sphere").is_checked()
    page.keyboard.down("Shift")
    try:
        drag(page, view, -40, 10, start=(200, 170))
    finally:
        page.keyboard.up("Shift")
    poll(lambda: _checkbox(page, engine, "sphere").is_checked(), "shift + drag to switch the ball on", 30, 0.2,
         page=page)
    assert _kernel_state(page)[engine]["ball"] is True

    before = set((marimo_root / "output").glob("*.png")) if (marimo_root / "output").exists() else set()
    _button(page, engine, "Save PNG").click()
    poll(lambda: "saved" in _status(page, engine), "Save PNG to say where it wrote", 60, 0.3, page=page)
    new = sorted(set((marimo_root / "output").glob("*.png")) - before)
    assert len(new) == 1, new
    import imageio.v3 as iio

    png = iio.imread(new[0])[..., :3].astype(np.int32)
    assert png.shape[:2] == (480, 640)  # 2x the 320 x 240 view (the PNG size dropdown's default)
    assert _grass_and_sky(png)[0] > 0.3

    # a teaching view: "colour by" LOD paints the blades in the LOD classes' colours, and the legend says so
    from grasswidget.core.teaching import legend

    still = _pixels(page, engine)
    colour = _root(page, engine).locator(".gwm-dropdown", has=page.locator(".gwm-label", has_text=panel_label(
        "color_by")))
    colour.locator("select").select_option(label="lod")
    first_class = legend("lod")[0][0]
    poll(lambda: first_class in _status(page, engine), "the legend of the LOD colours", 30, 0.2, page=page)
    _changes(page, engine, still, f"the {engine} view to draw the LOD colours", timeout=30)

    chart = _root(page, engine).locator(".gw-trace-chart").first
    assert not chart.is_visible()
    dropdown = _root(page, engine).locator(".gwm-dropdown", has=page.locator(".gwm-label", has_text="chart"))
    dropdown.locator("select").select_option(label="culling")
    poll(lambda: _kernel_state(page)[engine]["chart"] == "culling", "the chart choice to reach the kernel", 30, 0.2,
         page=page)
    _button(page, engine, "Play").click()
    poll(lambda: chart.is_visible() and int(chart.get_attribute("data-points") or 0) > 1,
         f"the {engine} engine's culling chart to draw samples", 60, 0.5, page=page)
    _root(page, engine).screenshot(path=str(_artifacts() / f"marimo-{engine}-ball-lod-chart.png"))


FALLBACK_NOTEBOOK = textwrap.dedent('''
    import marimo

    app = marimo.App(width="full")


    @app.cell
    def _():
        import grasswidget as gw
        w = gw.GrassWidget(512, backend="browser", size=(240, 180))
        w
        return (w,)


    if __name__ == "__main__":
        app.run()
''')


def test_fallback_to_the_kernel_engine_in_marimo(tmp_path, browser):
    (tmp_path / "fallback.py").write_text(FALLBACK_NOTEBOOK)
    with MarimoServer(tmp_path / "fallback.py") as server:
        page = browser.new_page()  # a tab of the session's Chromium without WebGPU
        try:
            page.goto(server.base_url, wait_until="domcontentloaded", timeout=60_000)
            root = page.locator(".grasswidget-marimo").first
            poll(lambda: root.locator("img.renderview-view").count() == 1 and
                 root.locator("canvas.grasswidget-canvas").count() == 0,
                 "the kernel engine's view to replace the browser engine's", 120, 0.5, page=page)
            text = root.locator(".gwm-root").first
            poll(lambda: "the kernel renders the view" in text.inner_text(), "the message saying why", 30, 0.3,
                 page=page)
            poll(lambda: re.search(r"[\d.]+ frames/s", text.inner_text()), "frames to stream", 60, 0.5, page=page)
            view = root.locator("img.renderview-view").first

            def meadow():
                import imageio.v3 as iio

                px = iio.imread(view.screenshot(), extension=".png")[..., :3].astype(np.int32)
                grass, sky = _grass_and_sky(px)
                return grass > 0.15 and sky > 0.5, (grass, sky)  # 512 blades: a sparser meadow
            grass, sky = poll(meadow, "grass under a sky in the kernel engine's view", 30, 0.5, page=page)
            root.screenshot(path=str(_artifacts() / "marimo-fallback.png"))
            print(f"\n[marimo fallback] grass {grass:.0%}, sky {sky:.0%}")
        except BaseException:
            print("\n[marimo log]\n" + server.log_text(4000) + "\n[console]\n" + "\n".join(browser.console[-40:]))
            raise
        finally:
            page.close()


# ---------------------------------------------------------------- backend="auto" in marimo
# The kernel renders on lavapipe (a CPU adapter) here, so the page's adapter decides (as in
# test_engine_auto_browser.py for JupyterLab). One notebook, one server, a page (a session of its
# own) per outcome: the simulated hardware adapter must be in place before the page loads.

AUTO_NOTEBOOK = textwrap.dedent('''
    import marimo

    app = marimo.App(width="full")


    @app.cell
    def _():
        import marimo as mo

        import grasswidget as gw
        w = gw.GrassWidget(512, size=(240, 180))
        w
        return gw, mo, w


    @app.cell
    def _(mo):
        asker = mo.ui.run_button(label="which engine runs")
        asker
        return (asker,)


    @app.cell
    def _(asker, mo, w):
        mo.stop(not asker.value)
        mo.md(f"<code class='auto-backend'>{w.backend}</code>")
        return


    if __name__ == "__main__":
        app.run()
''')

SIMULATED_GPU = "globalThis.__grasswidgetTestAdapterInfo = {vendor: 'nvidia', architecture: 'ampere', fallback: false};"


@pytest.fixture(scope="module")
def auto_server(tmp_path_factory, webgpu_chromium):
    root = tmp_path_factory.mktemp("marimo-auto")
    (root / "auto.py").write_text(AUTO_NOTEBOOK)
    with MarimoServer(root / "auto.py") as server:
        yield server, webgpu_chromium  # each test opens its own tab


def _backend_from_a_later_cell(page):
    """Run the later cell (its button) and read what it printed: ``w.backend`` in the kernel."""
    page.get_by_role("button", name="which engine runs").first.click()
    shown = page.locator("code.auto-backend").first
    shown.wait_for(timeout=60_000)
    return shown.inner_text().strip()


def _auto_page(auto_server, simulated_gpu):
    server, browser = auto_server
    page = browser.new_page()
    if simulated_gpu:
        page.add_init_script(SIMULATED_GPU)
    page.goto(server.base_url, wait_until="domcontentloaded", timeout=60_000)
    return server, browser, page


def test_auto_with_swiftshader_stays_on_the_kernel_engine_in_marimo(auto_server):
    server, browser, page = _auto_page(auto_server, simulated_gpu=False)
    try:
        root = page.locator(".grasswidget-marimo").first
        poll(lambda: root.locator("img.renderview-view").count() == 1, "the kernel engine's view", 120, 0.5,
             page=page)
        text = root.locator(".gwm-root").first
        reason = ("kernel engine: the kernel renders on a CPU adapter (llvmpipe) and this browser's WebGPU adapter "
                  "is a CPU fallback too (google swiftshader)")
        poll(lambda: reason in text.inner_text(), "the message line to say why the kernel engine stays", 60, 0.3,
             page=page)
        poll(lambda: re.search(r"[\d.]+ frames/s", text.inner_text()), "kernel frames to stream", 60, 0.5, page=page)
        view = root.locator("img.renderview-view").first

        def meadow():
            import imageio.v3 as iio

            px = iio.imread(view.screenshot(), extension=".png")[..., :3].astype(np.int32)
            grass, sky = _grass_and_sky(px)
            return grass > 0.15 and sky > 0.5, (grass, sky)  # 512 blades: a sparser meadow
        poll(meadow, "grass under a sky in the kernel engine's view", 30, 0.5, page=page)
        assert root.locator("canvas.grasswidget-canvas").count() == 0  # no browser engine was started
        assert _backend_from_a_later_cell(page) == "kernel"
    except BaseException:
        print("\n[marimo log]\n" + server.log_text(4000) + "\n[console]\n" + "\n".join(browser.console[-40:]))
        raise
    finally:
        page.close()


def test_auto_with_a_hardware_adapter_switches_to_the_browser_engine_in_marimo(auto_server):
    server, browser, page = _auto_page(auto_server, simulated_gpu=True)
    try:
        root = page.locator(".grasswidget-marimo").first
        # The stage follows the switch: the browser engine's canvas replaces jupyter-rfb's view.
        poll(lambda: root.locator("canvas.grasswidget-canvas").count() == 1 and
             root.locator("img.renderview-view").count() == 0,
             "the browser engine's canvas to replace the kernel engine's view", 120, 0.5, page=page)
        text = root.locator(".gwm-root").first
        reason = ("browser engine: the kernel renders on a CPU adapter (llvmpipe) and this browser offers a GPU "
                  "(nvidia ampere)")
        poll(lambda: reason in text.inner_text(), "the message line to say why the browser engine runs", 60, 0.3,
             page=page)
        canvas = root.locator("canvas.grasswidget-canvas").first
        canvas.scroll_into_view_if_needed()
        # engine.js counts the frames it drew on the canvas (marimo's shadow DOM: asked through the locator)
        drawn = lambda: canvas.evaluate("c => c.grasswidgetFramesDrawn || 0")  # noqa: E731
        first = drawn()
        poll(lambda: (drawn() >= first + 5, drawn()), "5 browser-engine frames", 90, 0.3, page=page)

        def meadow():
            import imageio.v3 as iio

            px = iio.imread(canvas.screenshot(), extension=".png")[..., :3].astype(np.int32)
            grass, sky = _grass_and_sky(px)
            return grass > 0.15 and sky > 0.5, (grass, sky)
        grass, sky = poll(meadow, "grass under a sky in the browser engine's canvas", 30, 0.5, page=page)
        assert _backend_from_a_later_cell(page) == "browser"
        root.screenshot(path=str(_artifacts() / "marimo-auto-browser.png"))
        print(f"\n[marimo auto, simulated GPU] grass {grass:.0%}, sky {sky:.0%}; screenshot in {_artifacts()}")
    except BaseException:
        print("\n[marimo log]\n" + server.log_text(4000) + "\n[console]\n" + "\n".join(browser.console[-40:]))
        raise
    finally:
        page.close()
