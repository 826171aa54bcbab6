"""The widget's layouts on the Python side: names, view sizes, folding and the camera bar's
two-way links (the pixels are measured in Chromium by tests/e2e/test_camera_and_layout.py)."""

import pytest

import grasswidget as gw
from grasswidget.errors import GrassValueError

pytest.importorskip("jupyter_rfb")


def test_lecture_layout_folds_the_panel_and_more_unfolds_it():
    w = gw.GrassWidget(blades=64, layout="lecture")
    try:
        assert w.layout_mode == "lecture" and w.size == (1280, 720) and w.panel_folded
        assert isinstance(w.layout, __import__("ipywidgets").Layout)  # ipywidgets' own trait untouched
        bar = w.camera_bar
        assert bar.play_button in bar.row.children and bar.more_button.description == "more"
        assert w.children[0].children[0] is w.view.widget and w.children[1].children[0] is bar.row
        more = w.children[1].children[1]
        assert more.layout.display == "none" and list(more.children) == [*w.panel.rows, w.lab_bench.control]
        bar.more_button.value = True  # the "more" click
        assert not w.panel_folded and more.layout.display == "" and bar.play_button not in bar.row.children
        w.panel_folded = True  # from code: the button follows
        assert bar.more_button.value is False and more.layout.display == "none"
        assert w.panel.view_size == (1280, 720)  # Save PNG multiplies the view's size
        bar.play_button.click()
        assert w.playing is False and bar.play_button.description == "Play"
        bar.preset_buttons["top"].click()
        cam = w.camera_state
        assert cam["position"][1] > 15 and abs(cam["position"][0] - cam["target"][0]) < 1
    finally:
        w.close()


def test_default_layout_and_bad_names():
    with pytest.raises(GrassValueError, match="'default', 'lecture'"):
        gw.GrassWidget(blades=64, layout="projector")
    w = gw.GrassWidget(blades=64, size=(400, 300))
    try:
        assert w.layout_mode == "default" and w.size == (400, 300) and not w.panel_folded
        assert w.camera_bar.play_button not in w.camera_bar.row.children  # the panel's own play button shows
        w.camera_bar.floor_checkbox.value = False
        assert w.camera_floor == "ground"
        w.look_from("home")
    finally:
        w.close()
