"""Input as a user gives it: a mouse drag at human speed over a view, and the ipywidgets
controls of a panel (sliders, buttons, checkboxes, dropdowns) found by their labels.
"""

from __future__ import annotations

import re
from typing import Optional

from .polling import HarnessError, HarnessTimeout, poll


def drag(
    page,
    locator,
    dx: float,
    dy: float,
    *,
    start: Optional[tuple] = None,
    steps: int = 20,
    step_ms: float = 40,
    hold_ms: float = 150,
    button: str = "left",
) -> None:
    """Drag with the mouse over ``locator`` by (dx, dy) CSS pixels, at human
    speed (``steps`` moves ``step_ms`` apart, ``hold_ms`` pauses after press
    and before release) so jupyter-rfb's 20 ms move throttle keeps the
    events. ``start`` is an (x, y) offset within the element; default its
    centre. The fixed pauses here are pacing, not waits for a condition."""
    locator.scroll_into_view_if_needed()
    box = locator.bounding_box()
    if box is None:
        raise HarnessError("drag: element is not visible")
    sx, sy = start if start is not None else (box["width"] / 2, box["height"] / 2)
    x0, y0 = box["x"] + sx, box["y"] + sy
    m = page.mouse
    m.move(x0, y0)
    page.wait_for_timeout(step_ms)
    m.down(button=button)
    page.wait_for_timeout(hold_ms)
    for i in range(1, steps + 1):
        m.move(x0 + dx * i / steps, y0 + dy * i / steps)
        page.wait_for_timeout(step_ms)
    page.wait_for_timeout(hold_ms)
    m.up(button=button)


def _exact(text: str):
    return re.compile(r"^\s*" + re.escape(text) + r"\s*$")


def _one(locator, what: str, candidates_js: Optional[str] = None, page=None, timeout: float = 10.0):
    """Wait until ``locator`` matches exactly one element; clear error otherwise."""

    def check():
        n = locator.count()
        return n == 1, n

    try:
        poll(check, what, timeout, 0.2, page=page)
    except HarnessTimeout as exc:
        extra = ""
        if candidates_js and page is not None:
            extra = f"; present on the page: {page.evaluate(candidates_js)!r}"
        raise HarnessTimeout(f"{exc}{extra}") from None
    return locator


_JS_SLIDER_LABELS = """() => Array.from(document.querySelectorAll('.widget-slider')).map(
  (s) => { const l = s.querySelector('.widget-label:not(.widget-readout)'); return l ? l.textContent : ''; })"""


def panel_label(trait: str) -> str:
    """The label the widget's panel shows for a GrassParams (or widget) trait, e.g.
    ``panel_label("gravity") == "gravity (m/s²)"`` (grasswidget.notebook.panel.control_label)."""
    import grasswidget as gw
    from grasswidget.notebook.panel import control_label

    traits = {**gw.GrassWidget.class_traits(), **gw.GrassParams.class_traits()}
    return control_label(trait, traits.get(trait))


def _slider(page, description: str, timeout: float):
    loc = page.locator(".widget-slider").filter(
        has=page.locator(".widget-label:not(.widget-readout)", has_text=_exact(description))
    )
    return _one(loc, f"exactly one slider labelled {description!r}", _JS_SLIDER_LABELS, page, timeout)


def slider_readout(page, description: str, timeout: float = 10.0) -> str:
    """Text of the readout of the slider labelled ``description``."""
    return _slider(page, description, timeout).locator(".widget-readout").inner_text().strip()


def set_slider(page, description: str, value: float, timeout: float = 10.0, check: bool = True) -> str:
    """Set an ipywidgets (Int/Float)Slider, found by its description label,
    by typing ``value`` into its editable readout and pressing Enter, like a
    user. With ``check`` waits until the readout shows the value (within
    0.5 % of the slider's visible precision). Returns the readout text.
    The kernel side is *not* checked: use :func:`wait_for_kernel`."""
    slider = _slider(page, description, timeout)
    readout = slider.locator(".widget-readout")
    if readout.get_attribute("contenteditable") != "true":
        raise HarnessError(f"slider {description!r} has no editable readout (readout=False or disabled?)")
    readout.scroll_into_view_if_needed()
    readout.click()
    readout.fill(str(value))
    readout.press("Enter")
    if not check:
        return readout.inner_text().strip()

    def ok():
        text = readout.inner_text().strip()
        try:
            shown = float(text.replace("\u2212", "-"))
        except ValueError:
            return False, text
        decimals = len(text.split(".")[1]) if "." in text else 0
        return abs(shown - float(value)) <= 0.5 * 10 ** (-decimals) + 1e-9, text

    return poll(ok, f"slider {description!r} readout to show {value}", timeout, 0.1, page=page)


def click_button(page, text: str, timeout: float = 10.0) -> None:
    """Click the ipywidgets Button (or ToggleButton) whose text is ``text``."""
    loc = page.locator("button.jupyter-button").filter(has_text=_exact(text))
    js = "() => Array.from(document.querySelectorAll('button.jupyter-button')).map((b) => b.textContent)"
    _one(loc, f"exactly one widget button {text!r}", js, page, timeout).click()


def toggle_checkbox(page, description: str, value: Optional[bool] = None, timeout: float = 10.0) -> bool:
    """Click the ipywidgets Checkbox labelled ``description`` (or, with
    ``value``, set it to that state). Returns the new checked state."""
    box = page.locator(".widget-checkbox").filter(
        has=page.locator(".widget-label-basic span", has_text=_exact(description))
    )
    js = ("() => Array.from(document.querySelectorAll('.widget-checkbox .widget-label-basic span'))"
          ".map((s) => s.textContent)")
    inp = _one(box, f"exactly one checkbox labelled {description!r}", js, page, timeout).locator(
        "input[type=checkbox]"
    )
    if value is None:
        before = inp.is_checked()
        inp.click()
        poll(lambda: (inp.is_checked() != before, inp.is_checked()), f"checkbox {description!r} to toggle",
             timeout, 0.1, page=page)
    else:
        inp.set_checked(bool(value))
    return inp.is_checked()


def choose_option(page, description: str, option: str, timeout: float = 10.0) -> str:
    """Choose ``option`` (its text) in the ipywidgets Dropdown labelled ``description``,
    e.g. a panel's auto / on / off switch. Returns the chosen option's text."""
    box = page.locator(".widget-dropdown").filter(
        has=page.locator("label.widget-label", has_text=_exact(description))
    )
    js = ("() => Array.from(document.querySelectorAll('.widget-dropdown label.widget-label'))"
          ".map((s) => s.textContent)")
    select = _one(box, f"exactly one dropdown labelled {description!r}", js, page, timeout).locator("select")
    select.select_option(label=option)
    poll(lambda: (select.evaluate("(s) => s.options[s.selectedIndex].text") == option, None),
         f"dropdown {description!r} to show {option!r}", timeout, 0.1, page=page)
    return option
