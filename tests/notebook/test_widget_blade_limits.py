"""The widget's blade count goes through the same memory and GPU-buffer check as GrassScene: a count
that does not fit is refused with the count and the limit on the message line, the slider never
offers more than fits."""

import pytest

pytest.importorskip("ipywidgets")

import grasswidget as gw  # noqa: E402


def test_widget_blade_count_uses_the_same_check(widget):
    old = widget.blade_count
    with pytest.raises(gw.BladeCountError, match=r"blades: count=1,000,000,000,000 .* at most"):
        widget.set_blades(10**12)
    assert widget.blade_count == old and widget.scene is not None
    # the blade control: the error shows in the message line and the control goes back
    control = widget.panel.blade_control
    control.choose(10**12)  # as if the control offered it: more blades than measured for, so it asks
    assert control.pending == 10**12 and widget.blade_count == old
    control.confirm()  # Apply
    assert "count=1,000,000,000,000" in widget.panel.message_line.value
    assert widget.panel.blade_slider.value == old and widget.blade_count == old
    # the slider never offers more than fits
    from grasswidget.gpu.field import max_blade_count

    fresh = gw.GrassWidget(blades=64, size=(160, 120))
    try:
        assert max(v for _label, v in fresh.panel.blade_slider.options) <= max_blade_count()
    finally:
        fresh.close()
