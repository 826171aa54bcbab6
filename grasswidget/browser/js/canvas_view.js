// @ts-check
// One display of the widget: a canvas of the engine (anywidget's render() makes one per display)
// and its input (orbit, pan and zoom drags, Shift-drag of the ball, Ctrl-click picks, keys).
// What a press does is Python's rule (grasswidget.core.interaction, frame_rules.input, executed by
// rules.js's PointerGesture, the same as the kernel engine's); what a drag does to the camera is
// rules.js's (Python's numbers, frame_rules.drag); what a key does Python decides (the "key" message).

import { add, invert4, mul4, scale, sub } from "./linalg.js";
import { PointerGesture, displayRatio, domButton, keyAction, orbitDrag, panDrag, wheelZoom } from "./rules.js";

/**
 * What a CanvasView needs of the engine that draws into it (the widget's GrassEngine, engine.js).
 * @typedef {object} CanvasEngine
 * @property {string} noteText the line shown over the canvas
 * @property {() => void} visibilityChanged a view came on or went off screen
 * @property {(width: number, height: number) => GPUTexture} depthFor a depth target of this size
 * @property {(aspect: number) => {view: ArrayLike<number>, proj: ArrayLike<number>}} matrices the camera's, column-major
 * @property {() => import("./rules.js").Camera} camera the camera now
 * @property {(camera: import("./rules.js").Camera, sync: boolean) => void} setCamera move it (sync: tell Python now)
 * @property {() => {drag: import("./rules.js").DragRules, input: import("./rules.js").InputRules,
 *   style: {ground: number[]}}} rules Python's frame_rules
 * @property {(type: string, message: string, extra?: object) => void} report a message to Python
 */
/**
 * A display's model handle (anywidget's; the live page's shim has the same methods).
 * @typedef {object} ViewModel
 * @property {(name: string) => any} get a synced trait's value
 */
/**
 * A press in progress: where the pointer was when a drag last moved the camera.
 * @typedef {object} Press
 * @property {number} x CSS px
 * @property {number} y CSS px
 * @property {PointerGesture} gesture
 */

/** The modifier names (jupyter-rfb's, as the rules name them) held during a DOM event.
 * @param {MouseEvent | KeyboardEvent} e @returns {string[]} */
function modifiersOf(e) {
  const held = [];
  if (e.shiftKey) held.push("Shift");
  if (e.ctrlKey) held.push("Control");
  if (e.altKey) held.push("Alt");
  if (e.metaKey) held.push("Meta");
  return held;
}

export class CanvasView {
  /**
   * @param {CanvasEngine} engine the widget's GrassEngine (engine.js)
   * @param {ViewModel} model this display's model handle (the same model as the engine's)
   * @param {HTMLElement} el where anywidget renders the display
   */
  constructor(engine, model, el) {
    this.engine = engine;
    this.model = model;       // this view's model handle (the same model as the engine's)
    this.el = el;
    /** @type {(() => void)[]} */
    this.handlers = [];
    /** @type {GPUCanvasContext | null} */
    this.context = null;
    /** @type {GPUTexture | null} */
    this.depth = null;
    /** @type {Press | null} */
    this.drag = null;
    this.onScreen = false;    // some pixel of the canvas is inside the viewport (IntersectionObserver)
    this.framesDrawn = 0;     // frames drawn into this canvas (also canvas.grasswidgetFramesDrawn, for tests)
    this.wrapper = document.createElement("div");
    this.canvas = /** @type {HTMLCanvasElement & {grasswidgetFramesDrawn?: number}} */ (document.createElement("canvas"));
    this.note = document.createElement("div");
    this.observer = new IntersectionObserver((entries) => {
      // Only changed entries come; the last one of this canvas says where it is now.
      for (const entry of entries) this.onScreen = entry.isIntersecting;
      this.engine.visibilityChanged();
    });
    this.buildDom();
    this.watchVisibility();
  }

  // At rest off screen: a view scrolled away, in a collapsed output or a hidden tab draws nothing.
  watchVisibility() {
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
    this.wrapper.className = "grasswidget-browser-view";
    this.wrapper.style.cssText = `position:relative;width:${w}px;height:${h}px;background:#cfe0ee;`;
    this.canvas.className = "grasswidget-canvas";
    this.canvas.tabIndex = 0;
    this.canvas.style.cssText = `width:${w}px;height:${h}px;display:block;outline:none;touch-action:none;`;
    this.note.className = "grasswidget-note";
    this.note.style.cssText = "position:absolute;left:8px;top:6px;font:12px sans-serif;color:#333;";
    this.note.textContent = this.engine.noteText;
    this.wrapper.append(this.canvas, this.note);
    this.el.append(this.wrapper);
    this.resize();

    /**
     * @template {keyof HTMLElementEventMap} K
     * @param {K} type @param {(e: HTMLElementEventMap[K]) => void} fn @param {AddEventListenerOptions} [opts]
     */
    const on = (type, fn, opts) => {
      this.canvas.addEventListener(type, fn, opts);
      this.handlers.push(() => this.canvas.removeEventListener(type, fn, opts));
    };
    on("pointerdown", (e) => this.onPointerDown(e));
    on("pointermove", (e) => this.onPointerMove(e));
    on("pointerup", (e) => this.onPointerUp(e));
    on("pointercancel", (e) => this.onPointerUp(e));
    on("wheel", (e) => this.onWheel(e), { passive: false });
    on("contextmenu", (e) => e.preventDefault());
    on("keydown", (e) => this.onKey(e));
  }

  /**
   * The engine's device is ready (again): draw into this canvas with it.
   * @param {GPUDevice} device @param {GPUTextureFormat} format
   */
  configure(device, format) {
    const context = /** @type {GPUCanvasContext} */ (this.canvas.getContext("webgpu"));
    this.context = context;
    context.configure({ device, format, alphaMode: "opaque" });
    if (this.depth) this.depth.destroy();
    this.depth = null;
  }

  resize() {
    const w = this.model.get("width"), h = this.model.get("height");
    // Rendered pixels per CSS pixel: the widget's pixel_ratio, else the display's (at most
    // Python's max_pixel_ratio: frame_rules.input).
    const rules = this.model.get("frame_rules");
    const asked = this.model.get("pixel_ratio");
    const ratio = rules && rules.input ? displayRatio(window.devicePixelRatio || 1, asked, rules.input)
      : (asked > 0 ? asked : 1);  // before Python's rules came: the CSS size
    this.wrapper.style.width = `${w}px`;
    this.wrapper.style.height = `${h}px`;
    this.canvas.style.width = `${w}px`;
    this.canvas.style.height = `${h}px`;
    this.canvas.width = Math.max(1, Math.round(w * ratio));
    this.canvas.height = Math.max(1, Math.round(h * ratio));
  }

  /**
   * This view's colour and depth targets for a frame (the depth texture follows the canvas size).
   * @returns {{color: GPUTextureView, depth: GPUTexture, w: number, h: number}}
   */
  targets() {
    const w = this.canvas.width, h = this.canvas.height;
    let depth = this.depth;
    if (!depth || depth.width !== w || depth.height !== h) {
      if (depth) depth.destroy();
      depth = this.depth = this.engine.depthFor(w, h);
    }
    const context = /** @type {GPUCanvasContext} */ (this.context);  // configured before any frame
    return { color: context.getCurrentTexture().createView(), depth, w, h };
  }

  /** @param {MouseEvent} e @returns {number[]} the pointer in normalized device coordinates */
  pointerNdc(e) {
    const r = this.canvas.getBoundingClientRect();
    return [((e.clientX - r.left) / r.width) * 2 - 1, 1 - ((e.clientY - r.top) / r.height) * 2];
  }

  /**
   * The view ray through the pointer: its points on the near (a) and far (b) planes.
   * @param {MouseEvent} e @returns {number[][]} [a, b]
   */
  pointerRay(e) {
    const [x, y] = this.pointerNdc(e);
    const { view, proj } = this.engine.matrices(this.canvas.width / this.canvas.height);
    const inv = invert4(mul4(proj, view));
    /** @param {number} z @returns {number[]} */
    const unproject = (z) => {
      const p = [0, 1, 2, 3].map((r) => inv[r] * x + inv[4 + r] * y + inv[8 + r] * z + inv[12 + r]);
      return [p[0] / p[3], p[1] / p[3], p[2] / p[3]];
    };
    return [unproject(0), unproject(1)];
  }

  /**
   * Where the view ray through the pointer meets the ground plane, or null (sky).
   * @param {MouseEvent} e @returns {number[] | null} [x, z]
   */
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

  /** What a press does is Python's rule (frame_rules.input), the kernel engine's too. @param {PointerEvent} e */
  onPointerDown(e) {
    this.canvas.focus();
    this.canvas.setPointerCapture(e.pointerId);
    const rules = this.engine.rules().input;
    const gesture = new PointerGesture(rules);
    this.drag = { x: e.clientX, y: e.clientY, gesture };
    if (gesture.down(e.clientX, e.clientY, domButton(e.button, rules), modifiersOf(e)) === "ball") this.sendBall(e, "down");
  }

  /** @param {PointerEvent} e */
  onPointerMove(e) {
    const d = this.drag;
    if (!d) return;
    const act = d.gesture.move(e.clientX, e.clientY);
    if (act === "ball") { this.sendBall(e, "move"); return; }
    if (act !== "pan" && act !== "pan_start" && act !== "orbit") return;  // a ctrl press still a click
    const dx = e.clientX - d.x, dy = e.clientY - d.y;
    d.x = e.clientX; d.y = e.clientY;
    const cam = this.engine.camera();
    if (act !== "orbit") {  // pan: move target and camera in the view plane
      const [position, target] = panDrag(cam.position, cam.target, cam.fov_deg, dx, dy, this.canvas.clientHeight);
      this.engine.setCamera({ ...cam, position, target }, false);
      return;
    }
    // orbit (the orbit limits, applied by setCamera, decide; never over a pole)
    this.engine.setCamera({ ...cam, position: orbitDrag(cam.position, cam.target, dx, dy, this.engine.rules().drag) }, false);
  }

  /** @param {PointerEvent} e */
  onPointerUp(e) {
    const d = this.drag;
    this.drag = null;
    if (!d) return;
    const act = d.gesture.up(e.clientX, e.clientY);
    if (act === "ball") this.sendBall(e, "up");
    else if (act === "inspect") this.sendPick(e);
    else if (act !== "cancel") this.engine.setCamera({ ...this.engine.camera() }, true);
  }

  /** @param {WheelEvent} e */
  onWheel(e) {
    e.preventDefault();
    const cam = this.engine.camera();
    this.engine.setCamera({ ...cam, position: wheelZoom(cam.position, cam.target, e.deltaY, this.engine.rules().drag) }, true);
  }

  /** @param {KeyboardEvent} e */
  onKey(e) {
    // Python decides what a key does (grasswidget.core.interaction.key_action, the kernel engine's too).
    if (e.ctrlKey || e.altKey || e.metaKey) return;
    // the play key (space) must not scroll the page as well
    if (keyAction(e.key, [], this.engine.rules().input) === "toggle_play") e.preventDefault();
    this.engine.report("key", "", { key: e.key, modifiers: e.shiftKey ? ["Shift"] : [] });
  }

  /** Ctrl + click: Python picks the blade on this ray and inspects it. @param {MouseEvent} e */
  sendPick(e) {
    const [a, b] = this.pointerRay(e);
    this.engine.report("pick", "", { origin: a, direction: sub(b, a) });
  }

  /** @param {MouseEvent} e @param {"down" | "move" | "up"} phase */
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
