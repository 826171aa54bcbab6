"""Frames and pixels of jupyter-rfb views (the kernel engine's picture in the page).

The view is ``div.renderview-wrapper > img.renderview-view``; every frame is a new ``blob:`` URL
in the img's ``src``. Frames are counted with a MutationObserver (:func:`install_frame_counter`).
While frames flow they are JPEG; about 0.3 s after the last one a lossless PNG follows, so call
:func:`wait_until_quiet` before comparing pixels exactly.
"""

from __future__ import annotations

import base64
from typing import Optional

from .polling import HarnessError, poll


#: JS: the frame counter starts again from 0, as if installed now (a notebook opened in a page
#: that already ran one counts its own frames only).
_JS_RESTART_COUNTER = "() => { const st = window.__gwFrames; if (st) { st.total = 0; st.last = performance.now(); } }"


def restart_frame_counter(page) -> None:
    """Count frames from 0 again, as if the counter were installed now (a notebook opened in a
    page that already ran one counts its own frames only); nothing happens where none is installed."""
    page.evaluate(_JS_RESTART_COUNTER)


VIEW_SELECTOR = "div.renderview-wrapper img.renderview-view"

_JS_INSTALL_COUNTER = r"""
() => {
  if (window.__gwFrames) return false;
  const st = window.__gwFrames = {total: 0, last: performance.now()};
  const obs = new MutationObserver((muts) => {
    const now = performance.now();
    for (const m of muts) {
      const t = m.target;
      if (t.tagName !== 'IMG' || !t.classList.contains('renderview-view')) continue;
      if (t.getAttribute('src') === m.oldValue) continue;
      t.__gwCount = (t.__gwCount || 0) + 1;
      t.__gwLast = now;
      st.total += 1;
      st.last = now;
    }
  });
  obs.observe(document.documentElement, {subtree: true, attributes: true, attributeFilter: ['src'], attributeOldValue: true});
  st.observer = obs;
  return true;
}
"""

_JS_FRAME_INFO = r"""
(index) => {
  const st = window.__gwFrames;
  if (!st) return null;
  const now = performance.now();
  if (index === null) return {count: st.total, sinceLast: now - st.last, now, views: document.querySelectorAll('img.renderview-view').length};
  const img = document.querySelectorAll('img.renderview-view')[index];
  if (!img) return {count: 0, sinceLast: null, now, views: document.querySelectorAll('img.renderview-view').length, missing: true};
  return {count: img.__gwCount || 0, sinceLast: now - (img.__gwLast || st.last), now, views: document.querySelectorAll('img.renderview-view').length};
}
"""


def install_frame_counter(page) -> bool:
    """Install (idempotently) a MutationObserver that counts ``src``
    changes of every ``img.renderview-view`` in the page, including views
    created later. :func:`open_notebook` calls this; call it again after a
    page reload. Returns True if it was newly installed."""
    return page.evaluate(_JS_INSTALL_COUNTER)


def _frame_info(page, index: Optional[int]) -> dict:
    info = page.evaluate(_JS_FRAME_INFO, index)
    if info is None:
        raise HarnessError("frame counter not installed; call install_frame_counter(page) first")
    return info


def frame_count(page, index: Optional[int] = None) -> int:
    """Frames seen since the counter was installed: over all views, or for
    the ``index``-th ``img.renderview-view`` in document order."""
    return _frame_info(page, index)["count"]


def frame_counts(page) -> list:
    """Frames seen since the counter was installed, per ``img.renderview-view`` in document
    order, all read at one instant (one evaluation: no frame arrives between two views' reads)."""
    counts = page.evaluate("() => window.__gwFrames ? [...document.querySelectorAll('img.renderview-view')]"
                           ".map((img) => img.__gwCount || 0) : null")
    if counts is None:
        raise HarnessError("frame counter not installed; call install_frame_counter(page) first")
    return counts


def wait_for_view(page, index: int = 0, timeout: float = 60.0):
    """Wait until the ``index``-th jupyter-rfb view exists, is visible and
    shows a decoded image; returns its locator.

    The view is scrolled into the viewport as soon as it exists: jupyter-rfb
    draws only for views the browser reports visible (IntersectionObserver),
    so a view left below the fold (e.g. after running a long notebook, which
    scrolls to its end) would never get its first frame."""
    loc = view_locator(page, index)

    def check():
        st = page.evaluate(
            """(i) => { const img = document.querySelectorAll('img.renderview-view')[i];
                 if (!img) return {exists: false};
                 let r = img.getBoundingClientRect();
                 if (r.bottom <= 0 || r.top >= window.innerHeight) {
                   img.scrollIntoView({block: 'center'});
                   r = img.getBoundingClientRect();
                 }
                 return {exists: true, w: r.width, h: r.height, natural: [img.naturalWidth, img.naturalHeight],
                         complete: img.complete, blob: (img.getAttribute('src') || '').startsWith('blob:')}; }""",
            index,
        )
        ok = st["exists"] and st["w"] > 0 and st["h"] > 0 and st["complete"] and st["natural"][0] > 1
        return bool(ok), st

    poll(check, f"jupyter-rfb view #{index} to show an image", timeout, 0.2, page=page)
    loc.scroll_into_view_if_needed()
    return loc


def wait_for_frames(page, n: int, timeout: float = 30.0, index: Optional[int] = None) -> int:
    """Wait until ``n`` *new* frames (counted from this call) have arrived,
    in any view or in view ``index``. Returns the frame count reached."""
    start = frame_count(page, index)

    def check():
        c = frame_count(page, index)
        return c - start >= n, c

    return poll(
        check,
        f"{n} new frames in {'any jupyter-rfb view' if index is None else f'view #{index}'} (had {start})",
        timeout,
        0.1,
        page=page,
    )


def frames_per_second(page, seconds: float = 3.0, index: Optional[int] = None) -> float:
    """Measure frames/s reaching the page over a ``seconds``-long window
    (uses the page's clock)."""
    a = _frame_info(page, index)
    page.wait_for_timeout(seconds * 1000)
    b = _frame_info(page, index)
    return (b["count"] - a["count"]) / ((b["now"] - a["now"]) / 1000.0)


def wait_until_quiet(page, quiet_s: float = 0.8, timeout: float = 20.0, index: Optional[int] = None) -> int:
    """Wait until no new frame has arrived for ``quiet_s`` seconds (all
    views, or view ``index``). jupyter-rfb sends a lossless PNG ~0.3 s
    after the last JPEG, so use quiet_s > 0.5 before exact pixel checks.
    Returns the frame count. Only succeeds once the animation has stopped
    (e.g. update mode "ondemand")."""

    def check():
        info = _frame_info(page, index)
        return info["sinceLast"] is not None and info["sinceLast"] >= quiet_s * 1000, info

    info = poll(check, f"the view(s) to receive no frame for {quiet_s} s", timeout, 0.1, page=page)
    return info["count"]


def view_locator(page, index: int = 0):
    """Locator of the ``index``-th jupyter-rfb ``img.renderview-view``."""
    return page.locator(VIEW_SELECTOR).nth(index)


_JS_VIEW_PIXELS = r"""
async (index) => {
  const img = document.querySelectorAll('img.renderview-view')[index];
  if (!img) return {error: 'no img.renderview-view #' + index + ' in the page'};
  const src = img.getAttribute('src');
  if (!img.complete || !img.naturalWidth) { try { await img.decode(); } catch (e) {} }
  if (!img.naturalWidth) return {error: 'view image not decoded (src ' + (src || '').slice(0, 40) + ')'};
  const c = document.createElement('canvas');
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const ctx = c.getContext('2d', {willReadFrequently: true});
  ctx.drawImage(img, 0, 0);
  const d = ctx.getImageData(0, 0, c.width, c.height).data;
  let s = '';
  const CH = 0x8000;
  for (let i = 0; i < d.length; i += CH) s += String.fromCharCode.apply(null, d.subarray(i, i + CH));
  return {w: c.width, h: c.height, b64: btoa(s), src};
}
"""


def view_pixels(page, index: int = 0):
    """The image currently shown by view ``index`` at its natural (frame)
    resolution, as a numpy array (h, w, 4) uint8 RGBA, decoded in the page
    through a canvas. JPEG while animating; call :func:`wait_until_quiet`
    first to get the final lossless PNG."""
    import numpy as np

    res = page.evaluate(_JS_VIEW_PIXELS, index)
    if res.get("error"):
        raise HarnessError(res["error"])
    arr = np.frombuffer(base64.b64decode(res["b64"]), dtype=np.uint8)
    return arr.reshape(res["h"], res["w"], 4).copy()


def view_screenshot(page, index: int = 0, path=None):
    """Screenshot of the view element as displayed (CSS size) as numpy
    (h, w, 4) uint8; also written to ``path`` if given."""
    import io

    import numpy as np
    from PIL import Image

    png = view_locator(page, index).screenshot(path=str(path) if path else None)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).copy()
