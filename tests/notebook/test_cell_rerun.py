"""Re-running a notebook cell closes the GrassWidget its earlier run made only when
nothing else holds it (grasswidget.notebook.cell_rerun): run in a real IPython shell, with its
output history (Out, _, _N), its post_run_cell event and its user namespace.

Each case makes a widget in cell "A", holds it somehow from another cell (as a student
would: a list, a dict, an attribute, a closure, another widget), re-runs cell "A" and
checks which widgets are closed.
"""

import gc

import pytest

pytest.importorskip("ipywidgets")
IPython = pytest.importorskip("IPython")

from conftest import WIDGET_SIZE  # noqa: E402

from grasswidget.notebook import cell_rerun  # noqa: E402

MAKE = f"import grasswidget as gw\nw = gw.GrassWidget(64, size={WIDGET_SIZE}, backend={{backend!r}})\nw\n"


@pytest.fixture
def notebook(monkeypatch):
    """An IPython shell whose cells carry a cell id: ``run(code, cell)``."""
    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance()
    cell = {"id": None}
    monkeypatch.setattr(cell_rerun, "current_cell_id", lambda: cell["id"])

    def run(code, cell_id):
        cell["id"] = cell_id
        result = shell.run_cell(code, store_history=True)
        cell["id"] = None
        result.raise_error()
        return result

    run.shell = shell
    yield run
    import grasswidget as gw

    for ref in [r for refs in cell_rerun.registered_widgets().values() for r in refs]:
        if isinstance(ref(), gw.GrassWidget):
            ref().close()
    shell.reset()
    InteractiveShell.clear_instance()
    gc.collect()


def _first_and_rerun(run, backend="browser", hold=None):
    """Cell A makes a widget (displayed: it lands in Out and _), ``hold`` (another cell) holds it,
    then cell A runs again. Returns (first widget, second widget)."""
    run(MAKE.format(backend=backend), "A")
    first = run.shell.user_ns["w"]
    if hold is not None:
        run(hold, "B")
    run(MAKE.format(backend=backend), "A")
    second = run.shell.user_ns["w"]
    assert first is not second and not second.closed
    return first, second


@pytest.mark.parametrize("backend", ["kernel", "browser"])
def test_a_plain_rerun_closes_the_earlier_widget(notebook, backend):
    """Only IPython's output history (Out[n], _, _n) and the widget's own wiring refer to
    the first widget: re-running the cell closes it."""
    run = notebook
    run(MAKE.format(backend=backend), "A")
    first = run.shell.user_ns["w"]
    assert any(v is first for v in run.shell.user_ns["Out"].values())  # the history holds it
    run(MAKE.format(backend=backend), "A")
    assert first.closed and not run.shell.user_ns["w"].closed
    assert cell_rerun.holder_of(run.shell.user_ns["w"], parts=run.shell.user_ns["w"].parts()) == "variable 'w'"


def test_without_a_cell_id_nothing_is_closed(notebook):
    """Plain IPython or a front end that sends no cell id: every widget stays open."""
    notebook(MAKE.format(backend="browser"), None)
    first = notebook.shell.user_ns["w"]
    notebook(MAKE.format(backend="browser"), None)
    assert not first.closed


@pytest.mark.parametrize("hold, holder", [
    ("keep = [w]", "variable 'keep'"),                                         # a list
    ("table = {'meadow': w}", "variable 'table'"),                             # a dict
    ("class Lesson:\n    pass\nlesson = Lesson()\nlesson.meadow = w", "variable 'lesson'"),   # an attribute
    ("def make(x):\n    return lambda: x.blade_count\ncount = make(w)", "variable 'count'"),  # a closure
    ("import ipywidgets as ipw\nipw.HBox([w])", "open widget HBox"),           # another widget, displayed
    ("import ipywidgets as ipw\nrow = ipw.HBox([ipw.Label('meadow')])\nrow.children += (w,)\ndel row",
     "open widget HBox"),                                                      # another widget, no variable
    ("v = w.view", "variable 'v'"),                                            # a part of it
])
def test_a_widget_held_elsewhere_stays_open(notebook, hold, holder):
    first, second = _first_and_rerun(notebook, hold=hold)
    assert not first.closed, f"held by {holder}: closing it would break what holds it"
    assert cell_rerun.holder_of(first, parts=first.parts()) == holder
    assert first.blade_count == 64  # still working


def test_another_grass_widget_holding_it_keeps_it_open(notebook):
    run = notebook
    run(MAKE.format(backend="browser"), "A")
    first = run.shell.user_ns["w"]
    run("other = gw.GrassWidget(64, backend='browser')\nother.companion = w\ndel other", "B")
    run(MAKE.format(backend="browser"), "A")
    assert not first.closed and cell_rerun.holder_of(first, parts=first.parts()) == "open widget GrassWidget"


def test_released_holders_let_the_next_rerun_close_it(notebook):
    """Once the list no longer holds it, the next re-run of the cell that made it closes it
    (it stays the cell's until then)."""
    run = notebook
    first, second = _first_and_rerun(run, hold="keep = [w]")
    assert not first.closed
    run("keep.clear()", "B")
    run(MAKE.format(backend="browser"), "A")
    assert first.closed and second.closed  # second was only in the history too


def test_the_registry_keeps_no_widget_alive(notebook):
    import weakref

    run = notebook
    run(MAKE.format(backend="browser"), "A")
    ref = weakref.ref(run.shell.user_ns["w"])
    run(MAKE.format(backend="browser"), "A")
    assert ref() is not None and ref().closed
    for value in ("1", "2", "3"):  # _, __ and ___ move on to other values
        run(value, "Z")
    run("Out.clear()", "Z")
    for space in (run.shell.user_ns, run.shell.user_ns_hidden):  # _1, _2 ...: the rest of the output history
        for name in [k for k in space if k.startswith("_") and k[1:].isdigit()]:
            del space[name]
    gc.collect()
    assert ref() is None, "a closed widget nothing holds is freed (the cell registry is weak)"


def test_the_search_names_module_globals_and_respects_its_limit():
    import types

    import grasswidget as gw

    w = gw.GrassWidget(64, size=WIDGET_SIZE, backend="browser")
    try:
        assert cell_rerun.holder_of(w, {}, parts=w.parts()) is None  # only this test's frame holds it
        module = types.ModuleType("lesson_module")
        module.meadow = w
        import sys

        sys.modules["lesson_module"] = module
        try:
            assert cell_rerun.holder_of(w, {}, parts=w.parts()) == "module 'lesson_module'"
        finally:
            del sys.modules["lesson_module"]
        report = {}
        assert cell_rerun.holder_of(w, {}, parts=w.parts(), limit=3, report=report) == "search limit"
        assert report["visited"] > 3
    finally:
        w.close()


def test_in_a_real_kernel_a_rerun_closes_only_what_nothing_holds():
    """The same in an ipykernel started by jupyter_client (comms, the rendercanvas event
    loop running the kernel canvas's frame scheduler), with JupyterLab's cellId metadata."""
    import os
    from pathlib import Path

    pytest.importorskip("ipykernel")
    from jupyter_client.manager import start_new_kernel

    root = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p))
    km, kc = start_new_kernel(kernel_name="python3", env=env)

    def run(code, cell):
        msg = kc.session.msg("execute_request", {"code": code, "silent": False, "store_history": True,
                                                 "user_expressions": {}, "allow_stdin": False,
                                                 "stop_on_error": True}, metadata={"cellId": cell})
        kc.shell_channel.send(msg)
        while True:
            reply = kc.get_shell_msg(timeout=120)
            if reply["parent_header"].get("msg_id") == msg["header"]["msg_id"]:
                break
        assert reply["content"]["status"] == "ok", reply["content"]
        return reply

    def value(expr):
        reply = kc.execute_interactive(f"print(repr({expr}))", timeout=60, output_hook=lambda m: out.append(m))
        assert reply["content"]["status"] == "ok"
        return [m["content"]["text"].strip() for m in out if m["msg_type"] == "stream"][-1]

    out = []
    try:
        for backend in ("kernel", "browser"):
            make = MAKE.format(backend=backend)
            run(make, f"make-{backend}")
            run("import weakref\nfirst = weakref.ref(w)", "probe")
            run(make, f"make-{backend}")
            assert value("first().closed") == "True", f"{backend}: a plain re-run closes the earlier widget"
            run("keep = [w]\nheld = weakref.ref(w)", "probe")
            run(make, f"make-{backend}")
            assert value("held().closed") == "False", f"{backend}: the widget in a list stays open"
            assert value("keep[0] is held() and not w.closed") == "True"
    finally:
        km.shutdown_kernel(now=True)
