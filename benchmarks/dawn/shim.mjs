// What a page gives the browser engine's ES module, for node + Dawn (dawn.node, the npm package
// `webgpu`) without a browser. Shared by run_engine.mjs (the engine played from a written state)
// and serve_engine.mjs (the engine answered by Python over stdin/stdout, as a kernel answers a page).
//
//   installPage(gpu)     globals: requestAnimationFrame (queued; runAnimationFrames() runs them),
//                        IntersectionObserver (every canvas on screen), document, window,
//                        navigator.gpu, devicePixelRatio 1
//   FakeElement / FakeCanvas   an `el` and a canvas whose getContext("webgpu") draws into a device
//                        texture (COPY_SRC: readCanvas() reads the last frame back)
//   Model                anywidget's model: get/set/save_changes/on/off/send; custom() delivers a
//                        message from Python
//   findCanvas(el)       the canvas the engine put under `el`
//   pump(canvasOf)       one turn of the page's loop (animation frames; when none submitted a frame,
//                        wait for the GPU queue instead of spinning: SwiftShader runs on the CPU)
//   readCanvas(device, canvas)   the canvas's current texture as RGBA bytes

import { performance } from "node:perf_hooks";

const rafQueue = [];
let rafId = 0;
/** The device the engine configured its canvas with (the last one). */
export const page = { lastDevice: null };

export function installPage(gpu) {
  globalThis.requestAnimationFrame = (cb) => { rafQueue.push([++rafId, cb]); return rafId; };
  globalThis.cancelAnimationFrame = (id) => {
    const at = rafQueue.findIndex(([k]) => k === id);
    if (at >= 0) rafQueue.splice(at, 1);
  };
  globalThis.IntersectionObserver = class {
    constructor(cb) { this.cb = cb; }
    observe(target) { queueMicrotask(() => this.cb([{ isIntersecting: true, target }])); }
    unobserve() {}
    disconnect() {}
  };
  globalThis.document = {
    visibilityState: "visible",
    createElement: (tag) => (tag === "canvas" ? new FakeCanvas() : new FakeElement(tag)),
    addEventListener() {}, removeEventListener() {},
  };
  globalThis.window = globalThis;
  globalThis.devicePixelRatio = 1;
  Object.defineProperty(globalThis, "navigator", { value: { gpu }, configurable: true, writable: true });
}

export class FakeElement {
  constructor(tag) { this.tagName = tag; this.style = {}; this.children = []; this.className = ""; this.textContent = ""; }
  append(...nodes) { this.children.push(...nodes); }
  appendChild(node) { this.children.push(node); return node; }
  remove() {}
  addEventListener() {}
  removeEventListener() {}
  setAttribute() {}
  focus() {}
  get isConnected() { return true; }
  getBoundingClientRect() { return { left: 0, top: 0, width: this.width || 0, height: this.height || 0 }; }
}

export class FakeCanvas extends FakeElement {
  constructor() { super("canvas"); this.width = 300; this.height = 150; this.context = null; }
  getContext(kind) {
    if (kind !== "webgpu") return null;
    if (!this.context) this.context = new CanvasContext(this);
    return this.context;
  }
}

// configure()/getCurrentTexture() backed by a device texture (COPY_SRC: the last frame is read back).
class CanvasContext {
  constructor(canvas) { this.canvas = canvas; this.texture = null; }
  configure(config) { this.config = config; page.lastDevice = config.device; this.texture = null; }
  unconfigure() { this.config = null; }
  getCurrentTexture() {
    const { width, height } = this.canvas;
    if (!this.texture || this.texture.width !== width || this.texture.height !== height) {
      if (this.texture) this.texture.destroy();
      this.texture = this.config.device.createTexture({
        size: [width, height], format: this.config.format,
        usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC, label: "canvas" });
    }
    return this.texture;
  }
}

/** The anywidget model: get/set/save_changes/on/off/send over a state object.
 * ``onSend(msg, buffers)`` gets what the module sends to Python; ``onSave(state)`` the traits it
 * set since the last save_changes() (both optional). */
export class Model {
  constructor(state, { onSend = null, onSave = null } = {}) {
    this.state = state; this.listeners = new Map(); this.sent = []; this.dirty = new Set();
    this.onSend = onSend; this.onSave = onSave;
  }
  get(name) { return this.state[name]; }
  set(name, value) { this.state[name] = value; this.dirty.add(name); this.fire(`change:${name}`, value); }
  // Python's value of a trait: no echo back to Python.
  setFromPython(name, value) { this.state[name] = value; this.dirty.delete(name); this.fire(`change:${name}`, value); }
  save_changes() {
    if (!this.dirty.size) return;
    const changed = Object.fromEntries([...this.dirty].map((name) => [name, this.state[name]]));
    this.dirty.clear();
    if (this.onSave) this.onSave(changed);
  }
  on(event, fn) { if (!this.listeners.has(event)) this.listeners.set(event, []); this.listeners.get(event).push(fn); }
  off(event, fn) { const l = this.listeners.get(event) || []; const k = l.indexOf(fn); if (k >= 0) l.splice(k, 1); }
  fire(event, ...a) { for (const fn of [...(this.listeners.get(event) || [])]) fn(...a); }
  send(msg, _callbacks, buffers) {
    this.sent.push({ msg, buffers });
    if (this.onSend) this.onSend(msg, buffers || []);
  }
  custom(msg, buffers = []) { this.fire("msg:custom", msg, buffers); }  // Python -> page
}

export function findCanvas(node) {
  if (node instanceof FakeCanvas) return node;
  for (const child of node.children || []) { const f = findCanvas(child); if (f) return f; }
  return null;
}

export const tick = () => new Promise((r) => setImmediate(r));

// One turn of the page's event loop: run the animation-frame callbacks asked for so far.
export function runAnimationFrames() {
  const due = rafQueue.splice(0);
  const now = performance.now();
  for (const [, cb] of due) cb(now);
  return due.length;
}

/** One turn of the loop: animation frames as fast as the engine takes them. When the turn submitted
 * nothing (the engine has its most frames in flight) it waits for the GPU queue of ``canvas``'s
 * device instead of spinning, so the loop leaves the CPU to the GPU work. */
export async function pump(canvas) {
  const before = canvas ? canvas.grasswidgetFramesDrawn || 0 : 0;
  const ran = runAnimationFrames();
  const submitted = canvas && (canvas.grasswidgetFramesDrawn || 0) > before;
  if (!submitted && page.lastDevice && canvas && canvas.context) await page.lastDevice.queue.onSubmittedWorkDone();
  else if (!ran) await new Promise((r) => setTimeout(r, 1));  // nothing asked for a frame: do not spin
  await tick();
}

export async function readCanvas(device, canvas) {
  const tex = canvas.context.getCurrentTexture();
  const w = tex.width, h = tex.height, row = Math.ceil((4 * w) / 256) * 256;
  const buf = device.createBuffer({ size: row * h, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
  const enc = device.createCommandEncoder();
  enc.copyTextureToBuffer({ texture: tex }, { buffer: buf, bytesPerRow: row }, [w, h]);
  device.queue.submit([enc.finish()]);
  await buf.mapAsync(GPUMapMode.READ);
  const src = new Uint8Array(buf.getMappedRange());
  const out = new Uint8Array(4 * w * h);
  const bgra = tex.format.startsWith("bgra");
  for (let y = 0; y < h; y++) {
    for (let x = 0; x < w; x++) {
      const s = y * row + 4 * x, d = 4 * (y * w + x);
      out[d] = src[s + (bgra ? 2 : 0)]; out[d + 1] = src[s + 1]; out[d + 2] = src[s + (bgra ? 0 : 2)]; out[d + 3] = src[s + 3];
    }
  }
  buf.unmap(); buf.destroy();
  return { w, h, rgba: out };
}
