// One display of the widget: a canvas of the engine (anywidget's render() makes one per display)
// and its input (orbit, pan and zoom drags, Shift-drag of the ball, Ctrl-click picks, keys).
// What a drag does to the camera is rules.js's (Python's numbers, frame_rules.drag); what a key
// does Python decides (the "key" message).

import { add, invert4, mul4, scale, sub } from "./linalg.js";
import { orbitDrag, panDrag, wheelZoom } from "./rules.js";

/** A canvas that draws the engine's meadow (one per display of the widget). */
export class CanvasView {
  /**
   * @param {object} engine the widget's GrassEngine (engine.js)
   * @param {object} model this display's model handle (the same model as the engine's)
   * @param {HTMLElement} el where anywidget renders the display
   */
  constructor(engine, model, el) {
    this.engine = engine;
    this.model = model;       // this view's model handle (the same model as the engine's)
    this.el = el;
    this.handlers = [];
    this.context = null;
    this.depth = null;
    this.onScreen = false;    // some pixel of the canvas is inside the viewport (IntersectionObserver)
    this.framesDrawn = 0;     // frames drawn into this canvas (also canvas.grasswidgetFramesDrawn, for tests)
    this.buildDom();
    this.watchVisibility();
  }

  // At rest off screen: a view scrolled away, in a collapsed output or a hidden tab draws nothing.
  watchVisibility() {
    this.observer = new IntersectionObserver((entries) => {
      // Only changed entries come; the last one of this canvas says where it is now.
      for (const entry of entries) this.onScreen = entry.isIntersecting;
      this.engine.visibilityChanged();
    });
    this.observer.observe(this.canvas);
  }

  // Whether this view can be seen now: on screen, attached to the page, in a visible tab.
  visible() {
    return this.onScreen && this.canvas.isConnected && document.visibilityState === "visible";
  }

  countFrame() {
    this.framesDrawn += 1;
    this.canvas.grasswidgetFramesDrawn = this.framesDrawn;
  }

  buildDom() {
    const w = this.model.get("width"), h = this.model.get("height");
    this.wrapper = document.createElement("div");
    this.wrapper.className = "grasswidget-browser-view";
    this.wrapper.style.cssText = `position:relative;width:${w}px;height:${h}px;background:#cfe0ee;`;
    this.canvas = document.createElement("canvas");
    this.canvas.className = "grasswidget-canvas";
    this.canvas.tabIndex = 0;
    this.canvas.style.cssText = `width:${w}px;height:${h}px;display:block;outline:none;touch-action:none;`;
    this.note = document.createElement("div");
    this.note.className = "grasswidget-note";
    this.note.style.cssText = "position:absolute;left:8px;top:6px;font:12px sans-serif;color:#333;";
    this.note.textContent = this.engine.noteText;
    this.wrapper.append(this.canvas, this.note);
    this.el.append(this.wrapper);
    this.resize();

    const on = (target, type, fn, opts) => {
      target.addEventListener(type, fn, opts);
      this.handlers.push(() => target.removeEventListener(type, fn, opts));
    };
    on(this.canvas, "pointerdown", (e) => this.onPointerDown(e));
    on(this.canvas, "pointermove", (e) => this.onPointerMove(e));
    on(this.canvas, "pointerup", (e) => this.onPointerUp(e));
    on(this.canvas, "pointercancel", (e) => this.onPointerUp(e));
    on(this.canvas, "wheel", (e) => this.onWheel(e), { passive: false });
    on(this.canvas, "contextmenu", (e) => e.preventDefault());
    on(this.canvas, "keydown", (e) => this.onKey(e));
  }

  // The engine's device is ready (again): draw into this canvas with it.
  configure(device, format) {
    this.context = this.canvas.getContext("webgpu");
    this.context.configure({ device, format, alphaMode: "opaque" });
    if (this.depth) this.depth.destroy();
    this.depth = null;
  }

  resize() {
    const w = this.model.get("width"), h = this.model.get("height");
    // Rendered pixels per CSS pixel: the widget's pixel_ratio, else the display's (at most 2).
    const asked = this.model.get("pixel_ratio");
    const ratio = asked > 0 ? asked : Math.min(window.devicePixelRatio || 1, 2);
    this.wrapper.style.width = `${w}px`;
    this.wrapper.style.height = `${h}px`;
    this.canvas.style.width = `${w}px`;
    this.canvas.style.height = `${h}px`;
    this.canvas.width = Math.max(1, Math.round(w * ratio));
    this.canvas.height = Math.max(1, Math.round(h * ratio));
  }

  // This view's colour and depth targets for a frame (the depth texture follows the canvas size).
  targets() {
    const w = this.canvas.width, h = this.canvas.height;
    if (!this.depth || this.depth.width !== w || this.depth.height !== h) {
      if (this.depth) this.depth.destroy();
      this.depth = this.engine.depthFor(w, h);
    }
    return { color: this.context.getCurrentTexture().createView(), depth: this.depth, w, h };
  }

  pointerNdc(e) {
    const r = this.canvas.getBoundingClientRect();
    return [((e.clientX - r.left) / r.width) * 2 - 1, 1 - ((e.clientY - r.top) / r.height) * 2];
  }

  // The view ray through the pointer: its points on the near (a) and far (b) planes.
  pointerRay(e) {
    const [x, y] = this.pointerNdc(e);
    const { view, proj } = this.engine.matrices(this.canvas.width / this.canvas.height);
    const inv = invert4(mul4(proj, view));
    const unproject = (z) => {
      const p = [0, 1, 2, 3].map((r) => inv[r] * x + inv[4 + r] * y + inv[8 + r] * z + inv[12 + r]);
      return [p[0] / p[3], p[1] / p[3], p[2] / p[3]];
    };
    return [unproject(0), unproject(1)];
  }

  // Where the view ray through the pointer meets the ground plane, or null (sky).
  groundPoint(e) {
    const [a, b] = this.pointerRay(e);
    const gy = this.model.get("frame_rules").style.ground[1];
    const d = sub(b, a);
    if (Math.abs(d[1]) < 1e-12) return null;
    const s = (gy - a[1]) / d[1];
    if (s <= 0) return null;
    const hit = add(a, scale(d, s));
    return [hit[0], hit[2]];
  }

  onPointerDown(e) {
    this.canvas.focus();
    this.canvas.setPointerCapture(e.pointerId);
    this.drag = { x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, button: e.button,
      ball: e.shiftKey && e.button === 0, pick: (e.ctrlKey || e.metaKey) && e.button === 0 };
    if (this.drag.ball) this.sendBall(e, "down");
  }

  onPointerMove(e) {
    const d = this.drag;
    if (!d) return;
    const dx = e.clientX - d.x, dy = e.clientY - d.y;
    d.x = e.clientX; d.y = e.clientY;
    if (d.ball) { this.sendBall(e, "move"); return; }
    const cam = this.engine.camera();
    if (d.button === 2 || e.ctrlKey) {  // pan: move target and camera in the view plane
      const [position, target] = panDrag(cam.position, cam.target, cam.fov_deg, dx, dy, this.canvas.clientHeight);
      this.engine.setCamera({ ...cam, position, target }, false);
      return;
    }
    // orbit (the orbit limits, applied by setCamera, decide; never over a pole)
    this.engine.setCamera({ ...cam, position: orbitDrag(cam.position, cam.target, dx, dy, this.engine.rules().drag) }, false);
  }

  onPointerUp(e) {
    const d = this.drag;
    this.drag = null;
    if (!d) return;
    if (d.ball) this.sendBall(e, "up");
    else if (d.pick && Math.hypot(e.clientX - d.x0, e.clientY - d.y0) < 4) this.sendPick(e);
    else this.engine.setCamera({ ...this.engine.camera() }, true);
  }

  onWheel(e) {
    e.preventDefault();
    const cam = this.engine.camera();
    this.engine.setCamera({ ...cam, position: wheelZoom(cam.position, cam.target, e.deltaY, this.engine.rules().drag) }, true);
  }

  onKey(e) {
    // Python decides what a key does (view_api.EngineView.on_key, shared with the kernel engine).
    if (e.ctrlKey || e.altKey || e.metaKey) return;
    if (e.key === " ") e.preventDefault();  // not the page's scroll
    this.engine.report("key", "", { key: e.key, modifiers: e.shiftKey ? ["Shift"] : [] });
  }

  // Ctrl + click: Python picks the blade on this ray and inspects it.
  sendPick(e) {
    const [a, b] = this.pointerRay(e);
    this.engine.report("pick", "", { origin: a, direction: sub(b, a) });
  }

  sendBall(e, phase) {
    const hit = this.groundPoint(e);  // null on the sky: Python decides (a press still switches the ball on)
    if (hit || phase === "down") this.engine.report("ball", "", { phase, x: hit ? hit[0] : null, z: hit ? hit[1] : null });
  }

  close() {
    for (const off of this.handlers) off();
    if (this.observer) this.observer.disconnect();
    if (this.depth) this.depth.destroy();
    if (this.context) { try { this.context.unconfigure(); } catch (e) { /* already gone */ } }
    this.wrapper.remove();
  }
}
