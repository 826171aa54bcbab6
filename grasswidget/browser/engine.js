// grasswidget's browser engine: the project's WGSL simulation, culling and
// ribbons, run in the notebook's browser with WebGPU (an anywidget ES module;
// shipped inside the wheel, nothing is fetched at run time).
//
// The engine only executes what Python describes (grasswidget/browser/view.py):
//   traits   engine_key (one engine per widget model), blade_data (rest pose,
//            N x 64 bytes), n_blades, shaders (WGSL text + binding maps + the
//            compute passes of a frame, in order), sim_uniform / cull_uniform /
//            material_uniform / sky_ground_uniform / ball_uniform (packed structs,
//            computed in Python: grasswidget.core.frame_data), sim_layout / stdinfo_layout
//            (field offsets), frame_rules ({clock: {dt, wind_period,
//            max_steps_per_frame}, orbit: OrbitLimits, style}), playing,
//            time_scale, camera ({position, target, fov_deg, near, far}),
//            collider_spheres / collider_grid (the colliders and their grid, bytes;
//            grasswidget.core.collider_grid; the balls are drawn from the spheres),
//            show_colliders, report_steps, stats_interval_ms (how often the stats
//            message goes; 500 when absent), width, height, pixel_ratio,
//            frustum_lines (the frozen culling camera's 12 edges, 24 x 3 float32;
//            empty: not frozen), inspect_uniform (u_inspect packed) and inspected
//            (the inspected blade ids).
//   messages step {n}, reset, read_state {id}, snapshot {id, width, height, filter}
//            (filter: grasswidget.core.frame_data.export_filter, the supersampling),
//            read_inspected {id}, sync {id} (answered at once: "synced"),
//            compile_simulate {id, shader, passes}, lose_device (tests).
// Occlusion culling (shaders.occlusion, grasswidget.browser.wgsl.BrowserShaders.occlusion): while
// u_cull.occlusion_phase (Python's bytes) is 1, each frame is drawn in two phases around a
// max-depth pyramid, as the kernel engine's grasswidget.gpu.occlusion.render_frame does; the
// functions of this engine that do it are grouped under "occlusion culling" below.
// The compute rasterizer of thin blades (shaders.compute_raster, BrowserShaders.compute_raster):
// while u_cull.compute_raster (Python's bytes) is 1, the compute passes marked only_if
// "compute_raster" run with each view size's per-pixel buffers, and a resolve draw follows the
// ribbons, as the kernel engine's grasswidget.gpu.render_frame does ("compute rasterizer" below).
// The browser answers with gpu_status (a trait), stats, state, snapshot,
// inspected, compiled, pick, error and device_lost messages. A compute pass or
// an overlay with "only_if" runs while its condition holds ("frozen",
// "inspecting"); a pass with sim_uniform "now" gets u_sim for the time of the
// next step (no steps) first, as the kernel's inspector does. Fixed steps: step(n) runs exactly n
// steps of dt; playing follows the wall clock with grasswidget.notebook.clock.SimClock's
// rules (SimClock below).
// Views at rest: a view that is not visible (scrolled away, a collapsed output, a hidden tab:
// an IntersectionObserver per canvas and document.visibilityState) draws nothing; with no view
// visible the engine simulates nothing, sends no stats and asks for no animation frame, and its
// clock stops as pause() stops it (SimClock.stop, Python's rule): on return simulated time goes
// on from where it stopped. canvas.grasswidgetFramesDrawn counts a view's frames (tests).
//
// One engine per widget model (GPU device, buffers, simulation, clock), however
// many times the widget is displayed: anywidget's initialize() makes it, each
// render() only adds a view (a canvas) of it, and every visible view draws the
// same meadow from the same camera.

const BLADE_STEPS_PER_DISPATCH = 1 << 24;
const STATS_INTERVAL_MS = 500;
const MAX_FRAMES_IN_FLIGHT = 2;
const WORKGROUP = 256;


// ------------------------------------------------------------------ small math (column-major 4x4)

function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
function norm(a) { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }

function mul4(a, b) {
  const out = new Float64Array(16);
  for (let c = 0; c < 4; c++) {
    for (let r = 0; r < 4; r++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      out[c * 4 + r] = s;
    }
  }
  return out;
}

function invert4(m) {
  const inv = new Float64Array(16);
  const a = m;
  inv[0] = a[5] * a[10] * a[15] - a[5] * a[11] * a[14] - a[9] * a[6] * a[15] + a[9] * a[7] * a[14] + a[13] * a[6] * a[11] - a[13] * a[7] * a[10];
  inv[4] = -a[4] * a[10] * a[15] + a[4] * a[11] * a[14] + a[8] * a[6] * a[15] - a[8] * a[7] * a[14] - a[12] * a[6] * a[11] + a[12] * a[7] * a[10];
  inv[8] = a[4] * a[9] * a[15] - a[4] * a[11] * a[13] - a[8] * a[5] * a[15] + a[8] * a[7] * a[13] + a[12] * a[5] * a[11] - a[12] * a[7] * a[9];
  inv[12] = -a[4] * a[9] * a[14] + a[4] * a[10] * a[13] + a[8] * a[5] * a[14] - a[8] * a[6] * a[13] - a[12] * a[5] * a[10] + a[12] * a[6] * a[9];
  inv[1] = -a[1] * a[10] * a[15] + a[1] * a[11] * a[14] + a[9] * a[2] * a[15] - a[9] * a[3] * a[14] - a[13] * a[2] * a[11] + a[13] * a[3] * a[10];
  inv[5] = a[0] * a[10] * a[15] - a[0] * a[11] * a[14] - a[8] * a[2] * a[15] + a[8] * a[3] * a[14] + a[12] * a[2] * a[11] - a[12] * a[3] * a[10];
  inv[9] = -a[0] * a[9] * a[15] + a[0] * a[11] * a[13] + a[8] * a[1] * a[15] - a[8] * a[3] * a[13] - a[12] * a[1] * a[11] + a[12] * a[3] * a[9];
  inv[13] = a[0] * a[9] * a[14] - a[0] * a[10] * a[13] - a[8] * a[1] * a[14] + a[8] * a[2] * a[13] + a[12] * a[1] * a[10] - a[12] * a[2] * a[9];
  inv[2] = a[1] * a[6] * a[15] - a[1] * a[7] * a[14] - a[5] * a[2] * a[15] + a[5] * a[3] * a[14] + a[13] * a[2] * a[7] - a[13] * a[3] * a[6];
  inv[6] = -a[0] * a[6] * a[15] + a[0] * a[7] * a[14] + a[4] * a[2] * a[15] - a[4] * a[3] * a[14] - a[12] * a[2] * a[7] + a[12] * a[3] * a[6];
  inv[10] = a[0] * a[5] * a[15] - a[0] * a[7] * a[13] - a[4] * a[1] * a[15] + a[4] * a[3] * a[13] + a[12] * a[1] * a[7] - a[12] * a[3] * a[5];
  inv[14] = -a[0] * a[5] * a[14] + a[0] * a[6] * a[13] + a[4] * a[1] * a[14] - a[4] * a[2] * a[13] - a[12] * a[1] * a[6] + a[12] * a[2] * a[5];
  inv[3] = -a[1] * a[6] * a[11] + a[1] * a[7] * a[10] + a[5] * a[2] * a[11] - a[5] * a[3] * a[10] - a[9] * a[2] * a[7] + a[9] * a[3] * a[6];
  inv[7] = a[0] * a[6] * a[11] - a[0] * a[7] * a[10] - a[4] * a[2] * a[11] + a[4] * a[3] * a[10] + a[8] * a[2] * a[7] - a[8] * a[3] * a[6];
  inv[11] = -a[0] * a[5] * a[11] + a[0] * a[7] * a[9] + a[4] * a[1] * a[11] - a[4] * a[3] * a[9] - a[8] * a[1] * a[7] + a[8] * a[3] * a[5];
  inv[15] = a[0] * a[5] * a[10] - a[0] * a[6] * a[9] - a[4] * a[1] * a[10] + a[4] * a[2] * a[9] + a[8] * a[1] * a[6] - a[8] * a[2] * a[5];
  let det = a[0] * inv[0] + a[1] * inv[4] + a[2] * inv[8] + a[3] * inv[12];
  det = det === 0 ? 1 : 1 / det;
  for (let i = 0; i < 16; i++) inv[i] *= det;
  return inv;
}

// Camera to world (columns: right, up, back, position) for a camera at eye looking at target.
function cameraWorld(eye, target) {
  const back = norm(sub(eye, target));
  let right = cross([0, 1, 0], back);
  if (Math.hypot(...right) < 1e-9) right = [1, 0, 0];
  right = norm(right);
  const up = cross(back, right);
  return new Float64Array([...right, 0, ...up, 0, ...back, 0, ...eye, 1]);
}

// Perspective projection with a vertical fov, WebGPU depth 0 (near) .. 1 (far).
function perspective(fovDeg, aspect, near, far) {
  const f = 1 / Math.tan((fovDeg * Math.PI) / 360);
  const m = new Float64Array(16);
  m[0] = f / aspect;
  m[5] = f;
  m[10] = far / (near - far);
  m[11] = -1;
  m[14] = (near * far) / (near - far);
  return m;
}


// ------------------------------------------------------------------ rules from Python, executed here

// grasswidget.notebook.clock.SimClock, line for line: wall seconds (times time_scale) spent in
// whole fixed steps of dt; at most maxSteps a frame, the rest dropped (slow motion).
export class SimClock {
  constructor(maxSteps) {
    this.maxSteps = maxSteps;
    this.running = false;
    this.last = null;
    this.acc = 0;
    this.lastSteps = 0;
    this.capped = false;
  }

  start(now) {
    if (!this.running) { this.running = true; this.last = now; }
  }

  stop() {
    this.running = false;
    this.last = null;
    this.acc = 0;
  }

  reset(now) {
    this.acc = 0;
    if (this.running) this.last = now;
  }

  // Steps owed for the wall time (seconds) since the last call; 0 while stopped.
  frameSteps(now, dt, timeScale) {
    if (!this.running) { this.lastSteps = 0; this.capped = false; return 0; }
    const wall = Math.max(0, now - this.last) * Math.max(0, timeScale);
    this.last = now;
    this.acc += wall;
    let n = Math.floor(this.acc / dt + 1e-9);
    this.capped = n > this.maxSteps;
    if (this.capped) { n = this.maxSteps; this.acc = 0; } else this.acc = Math.max(0, this.acc - n * dt);
    this.lastSteps = n;
    return n;
  }
}

function clamp(x, lo, hi) { return Math.min(Math.max(x, lo), hi); }

// grasswidget.core.orbit_limits.clamp_orbit, line for line: (position, target) moved the least way into
// the limits (an OrbitLimits as a dict): target into its box (the camera follows), distance
// into the zoom range, elevation into its range (keeping the azimuth).
// ------------------------------------------------------------------ exports: supersampling

const SRGB_TO_LINEAR = Float32Array.from({ length: 256 }, (_, i) => {
  const c = i / 255;
  return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
});

function linearToSrgb8(x) {
  const c = Math.min(Math.max(x, 0), 1);
  const s = c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055;
  return Math.round(s * 255);
}

// Filter an 8-bit picture of (width * f) x (height * f) pixels, rows `rowBytes` apart
// (sRGB as the canvas stores it; `bgra`: blue first), down to width x height RGBA with
// Python's separable filter {factor: f, first, weights} (frame_data.export_filter), in
// linear light with indices clamped to the picture: what pygfx's renderer does for the
// kernel engine's exports. Returns a Uint8Array of width * height * 4 (alpha 255).
export function downsample(src, width, height, rowBytes, bgra, filter) {
  const f = filter.factor, first = filter.first, wts = filter.weights, taps = wts.length;
  const sw = width * f, sh = height * f;
  const rx = bgra ? 2 : 0, bx = bgra ? 0 : 2;
  const clampTo = (i, n) => (i < 0 ? 0 : i >= n ? n - 1 : i);
  const rows = new Float32Array(width * sh * 3);  // filtered along x, all source rows
  for (let y = 0; y < sh; y++) {
    const line = y * rowBytes;
    for (let x = 0; x < width; x++) {
      let r = 0, g = 0, b = 0;
      for (let k = 0; k < taps; k++) {
        const i = line + 4 * clampTo(f * x + first + k, sw), w = wts[k];
        r += w * SRGB_TO_LINEAR[src[i + rx]];
        g += w * SRGB_TO_LINEAR[src[i + 1]];
        b += w * SRGB_TO_LINEAR[src[i + bx]];
      }
      const o = 3 * (y * width + x);
      rows[o] = r; rows[o + 1] = g; rows[o + 2] = b;
    }
  }
  const out = new Uint8Array(width * height * 4);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      let r = 0, g = 0, b = 0;
      for (let k = 0; k < taps; k++) {
        const i = 3 * (clampTo(f * y + first + k, sh) * width + x), w = wts[k];
        r += w * rows[i]; g += w * rows[i + 1]; b += w * rows[i + 2];
      }
      const o = 4 * (y * width + x);
      out[o] = linearToSrgb8(r); out[o + 1] = linearToSrgb8(g); out[o + 2] = linearToSrgb8(b); out[o + 3] = 255;
    }
  }
  return out;
}

export function clampOrbit(position, target, limits) {
  const L = limits;
  const c = [clamp(target[0], L.lo[0], L.hi[0]), 0, clamp(target[2], L.lo[1], L.hi[1])];
  const floor = L.ground_y === null || L.ground_y === undefined ? -Infinity : L.ground_y;
  c[1] = Math.min(Math.max(target[1], floor), L.top_y);
  const pos = add(position, sub(c, target));
  let off = sub(pos, c);
  let d = Math.hypot(...off);
  if (d < 1e-9) { off = [0, 0, 1]; d = 1e-9; }
  const dNew = clamp(d, L.min_distance, L.max_distance);
  let dir = scale(off, 1 / d);
  const el = Math.asin(clamp(dir[1] / Math.max(Math.hypot(...dir), 1e-12), -1, 1));
  let loEl;
  if (floor === -Infinity) loEl = -(L.max_elevation_deg * Math.PI) / 180;
  else loEl = Math.asin(clamp((L.ground_y + L.clearance - c[1]) / Math.max(dNew, 1e-9), -1, 1));
  const hiEl = (L.max_elevation_deg * Math.PI) / 180;
  const elNew = Math.min(Math.max(el, loEl), hiEl);
  if (elNew !== el) {
    let horizontal = [dir[0], 0, dir[2]];
    const h = Math.hypot(...horizontal);
    horizontal = h > 1e-9 ? scale(horizontal, 1 / h) : [0, 0, 1];
    dir = add(scale(horizontal, Math.cos(elNew)), [0, Math.sin(elNew), 0]);
  }
  return [add(c, scale(dir, dNew)), c];
}

// grasswidget.core.reference.hzb_layout, line for line: where each level of the max-depth pyramid
// lives in one float32 buffer, [offset, width, height, pitch] in texels, level 0 first. Level 0 is
// the depth buffer (rows every rowAlign-aligned pitch: Python's HZB_ROW_ALIGN, sent in
// shaders.occlusion.row_align); level k + 1 halves level k rounding up, down to 1 x 1, rows packed.
export function hzbLayout(width, height, rowAlign) {
  if (!(width >= 1 && height >= 1)) throw new Error(`hzbLayout needs a viewport of at least 1 x 1 pixels; got ${width} x ${height}`);
  let w = Math.floor(width), h = Math.floor(height);
  const pitch = Math.ceil(w / rowAlign) * rowAlign;
  const levels = [[0, w, h, pitch]];
  let offset = pitch * h;
  while (w > 1 || h > 1) {
    w = Math.ceil(w / 2); h = Math.ceil(h / 2);
    levels.push([offset, w, h, w]);
    offset += w * h;
  }
  return levels;
}

// ------------------------------------------------------------------ a view: one display of the widget

class GrassView {
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
    const target = cam.target, pos = cam.position;
    let off = sub(pos, target);
    if (d.button === 2 || e.ctrlKey) {  // pan: move target and camera in the view plane
      const world = cameraWorld(pos, target);
      const dist = Math.hypot(...off);
      const k = (2 * dist * Math.tan((cam.fov_deg * Math.PI) / 360)) / this.canvas.clientHeight;
      const right = [world[0], world[1], world[2]], up = [world[4], world[5], world[6]];
      const move = add(scale(right, -dx * k), scale(up, dy * k));
      this.engine.setCamera({ ...cam, position: add(pos, move), target: add(target, move) }, false);
      return;
    }
    const r = Math.hypot(...off);
    let az = Math.atan2(off[0], off[2]);
    let el = Math.asin(Math.max(-1, Math.min(1, off[1] / r)));
    az -= dx * 0.008;
    el = Math.max(-1.55, Math.min(1.55, el + dy * 0.008));  // the orbit limits below decide; never over a pole
    off = [r * Math.cos(el) * Math.sin(az), r * Math.sin(el), r * Math.cos(el) * Math.cos(az)];
    this.engine.setCamera({ ...cam, position: add(target, off) }, false);
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
    const off = sub(cam.position, cam.target);
    const k = Math.exp(Math.max(-0.5, Math.min(0.5, e.deltaY * 0.001)));
    this.engine.setCamera({ ...cam, position: add(cam.target, scale(off, k)) }, true);
  }

  onKey(e) {
    // Python decides what a key does (view_api.GrassView.on_key, shared with the kernel engine).
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

// ------------------------------------------------------------------ the engine: one per widget model

class GrassEngine {
  constructor(model) {
    this.model = model;       // the model handle of anywidget's initialize(): lives as long as the model
    this.views = new Set();
    this.queue = [];          // messages that arrived before the device was ready
    this.ready = false;
    this.starting = false;
    this.closed = false;
    this.device = null;
    this.stepCount = 0;
    // The clock's step cap is read from frame_rules every frame (Python sends it after the model opens).
    this.clock = new SimClock(1);
    this.inFlight = 0;
    this.frames = 0;          // frames whose GPU work completed
    this.statsFrames = 0;
    this.statsTime = performance.now();
    this.visible = null;      // per LOD class, from the last args readback
    this.argsReadPending = false;
    this.lastFrameMs = null;
    this.expectLoss = false;
    this.recoveries = 0;
    this.noteText = "starting WebGPU…";
    // Start-up milestones (performance.now() ms), read by benchmarks.
    this.timing = { created: performance.now() };
    this.listen();
    this.onPageVisibility = () => this.visibilityChanged();
    document.addEventListener("visibilitychange", this.onPageVisibility);
  }

  rules() { return this.model.get("frame_rules"); }

  listen() {
    this.onMsg = (msg, buffers) => { this.onMessage(msg, buffers); };
    this.model.on("msg:custom", this.onMsg);
    const names = ["cull_uniform", "material_uniform", "sky_ground_uniform", "ball_uniform", "collider_spheres", "collider_grid",
      "frame_rules", "blade_data", "width", "height", "pixel_ratio", "frustum_lines", "inspect_uniform"];
    this.listeners = names.map((name) => {
      const fn = () => this.onChange(name);
      this.model.on(`change:${name}`, fn);
      return [name, fn];
    });
  }

  // ---------------------------------------------------------------- views

  addView(view) {
    this.views.add(view);
    if (this.ready) view.configure(this.device, this.format);
    if (!this.device && !this.starting) this.start();  // the GPU starts with the first view
    this.scheduleFrame();
  }

  removeView(view) {
    this.views.delete(view);
    view.close();
  }

  // The views that can be seen now; none: the engine rests (no simulation, no drawing, no stats).
  visibleViews() { return [...this.views].filter((v) => v.visible()); }

  // A view was scrolled in or out of sight, or the tab was shown or hidden. Resting stops the
  // clock as pause() does (Python's SimClock.stop: no time is owed for the time out of sight),
  // so on return simulated time goes on from where it stopped, without a catch-up burst.
  visibilityChanged() {
    if (this.closed) return;
    if (this.visibleViews().length) this.scheduleFrame();
    else this.rest();
  }

  rest() {
    this.clock.stop();
    this.resting = true;
  }

  setNote(text) {
    this.noteText = text;
    for (const v of this.views) v.note.textContent = text;
  }

  camera() { return this.model.get("camera"); }

  // Set the camera (held to the orbit limits from Python); sync to Python at most every 100 ms unless asked.
  setCamera(cam, sync) {
    const [position, target] = clampOrbit(cam.position, cam.target, this.rules().orbit);
    this.model.set("camera", { ...cam, position, target });
    const now = performance.now();
    if (sync || !this.lastCamSync || now - this.lastCamSync > 100) {
      this.model.save_changes();
      this.lastCamSync = now;
    }
  }

  // ---------------------------------------------------------------- start-up

  status(state, detail) {
    this.model.set("gpu_status", { state, detail: detail || "" });
    this.model.save_changes();
  }

  async start() {
    this.starting = true;
    try {
      if (!navigator.gpu) {
        this.setNote("WebGPU is not available in this browser");
        this.status("unavailable", "navigator.gpu is missing");
        return;
      }
      const adapter = await navigator.gpu.requestAdapter();
      if (!adapter) {
        this.setNote("WebGPU is not available in this browser");
        this.status("unavailable", "requestAdapter() gave null");
        return;
      }
      const limits = {};
      for (const k of ["maxStorageBufferBindingSize", "maxBufferSize"]) limits[k] = adapter.limits[k];
      // The most storage buffers one of Python's shaders binds (occlusion culling's second pass
      // with the compute rasterizer: 10; WebGPU's default is 8), as far as the adapter allows.
      const storage = this.model.get("shaders").max_storage_buffers || 8;
      limits.maxStorageBuffersPerShaderStage = Math.min(Math.max(storage, 8), adapter.limits.maxStorageBuffersPerShaderStage);
      const device = await adapter.requestDevice({ requiredLimits: limits });
      if (this.closed) { device.destroy(); return; }
      const info = adapter.info || {};
      this.adapterText = [info.vendor, info.architecture, info.description].filter(Boolean).join(" ") || "WebGPU adapter";
      this.device = device;
      this.adapter = adapter;  // keep it referenced: Chromium rejects queue promises once the adapter is collected
      device.lost.then((lost) => this.onDeviceLost(device, lost));
      device.onuncapturederror = (ev) => this.report("error", `WebGPU error: ${ev.error.message}`);
      this.format = navigator.gpu.getPreferredCanvasFormat();
      for (const v of this.views) v.configure(device, this.format);
      this.timing.device = performance.now();
      await this.buildPipelines();
      this.timing.pipelines = performance.now();
      this.buildBuffers();
      this.timing.buffers = performance.now();
      this.setNote("");
      this.ready = true;
      this.status("ok", this.adapterText);
      const pending = this.queue;
      this.queue = [];
      for (const [msg, buffers] of pending) await this.onMessage(msg, buffers);
      this.scheduleFrame();
    } catch (err) {
      this.setNote(`WebGPU start failed: ${err.message || err}`);
      this.status("unavailable", `start failed: ${err.message || err}`);
    } finally {
      this.starting = false;
    }
  }

  report(type, message, extra) {
    try { this.model.send({ type, message, ...(extra || {}) }); } catch (e) { /* comm closed */ }
  }

  onDeviceLost(device, lost) {
    if (device !== this.device || this.closed) return;
    if (lost.reason === "destroyed" && !this.expectLoss) return;
    this.expectLoss = false;
    this.ready = false;
    this.device = null;
    const why = lost.message || lost.reason || "unknown";
    if (this.recoveries < 2) {
      this.recoveries += 1;
      this.report("device_lost", `the browser lost its WebGPU device (${why}); restarting the browser engine from the rest pose`);
      this.stepCount = 0;
      this.start();
    } else {
      this.report("device_lost", `the browser lost its WebGPU device (${why}) again; giving up`);
      this.status("unavailable", `device lost: ${why}`);
    }
  }

  // A module compiled from one rendered shader; throws with the compiler's messages.
  async compile(shader, label) {
    const device = this.device;
    device.pushErrorScope("validation");
    const module = device.createShaderModule({ code: shader.code, label });
    const info = await module.getCompilationInfo();
    const scopeError = await device.popErrorScope();
    const errors = info.messages.filter((m) => m.type === "error");
    if (errors.length || scopeError) {
      const err = new Error(`${label} does not compile: ` +
        (errors.map((m) => `line ${m.lineNum}:${m.linePos} ${m.message}`).join("; ") || scopeError.message));
      err.messages = errors.map((m) => ({ line: m.lineNum, column: m.linePos, message: m.message }));
      if (!errors.length && scopeError) err.messages = [{ line: null, column: null, message: scopeError.message }];
      throw err;
    }
    return module;
  }

  layoutFor(shader, visibility) {
    const entries = shader.bindings.map((b) => ({ binding: b.binding, visibility, buffer: { type: b.kind } }));
    return this.device.createBindGroupLayout({ entries });
  }

  async computePipeline(shader, label) {
    const module = await this.compile(shader, label);
    const layout = this.layoutFor(shader, GPUShaderStage.COMPUTE);
    this.device.pushErrorScope("validation");
    const pipeline = await this.device.createComputePipelineAsync({
      layout: this.device.createPipelineLayout({ bindGroupLayouts: [layout] }),
      compute: { module, entryPoint: "main" },
      label,
    });
    const err = await this.device.popErrorScope();
    if (err) throw new Error(`${label}: ${err.message}`);
    return { pipeline, layout, shader };
  }

  // The pipelines of a frame, from the shaders Python sent: the compute passes in the
  // order Python lists them (shaders.compute_passes: culling, LOD binning, draw order;
  // a new pass is one more entry there), the ribbon draws, sky and ground
  // (shaders/sky_ground.wgsl, as in the kernel engine) and the collider balls.
  async buildPipelines() {
    const device = this.device;
    const shaders = this.model.get("shaders");
    this.lodSegments = shaders.lod_segments;
    this.sim = await this.computePipeline(shaders.simulate, "simulate.wgsl");
    this.computePasses = [];
    for (const pass of shaders.compute_passes) {
      const pipe = await this.computePipeline(shaders[pass.shader], pass.label || pass.shader);
      this.computePasses.push({ ...pipe, dispatch: pass.dispatch, name: pass.shader, label: pass.label || pass.shader,
        onlyIf: pass.only_if, simNow: pass.sim_uniform === "now", sized: !!pass.sized });
    }
    this.depthFormat = (shaders.occlusion && shaders.occlusion.depth_format) || "depth24plus";
    const depthStencil = { format: this.depthFormat, depthWriteEnabled: true, depthCompare: "less" };
    const renderPipeline = this.renderPipeline = async (shader, label, { topology, depth, blend }) => {
      const module = await this.compile(shader, label);
      const layout = this.layoutFor(shader, GPUShaderStage.VERTEX | GPUShaderStage.FRAGMENT);
      const pipeline = await device.createRenderPipelineAsync({
        layout: device.createPipelineLayout({ bindGroupLayouts: [layout] }),
        vertex: { module, entryPoint: shader.vertex || "vs_main" },
        fragment: { module, entryPoint: shader.fragment || "fs_main", targets: [{ format: this.format, blend }] },
        primitive: { topology, cullMode: "none" },
        depthStencil: depth,
      });
      return { pipeline, layout, shader };
    };
    // Two sets of ribbon pipelines: the natural view's, and the colour-by views' (flat colours and
    // the culled blades' draw), which cost GPU draw time and are only used while color_by shows them.
    const ribbons = async (list, label) => {
      const pipes = [];
      for (let k = 0; k < list.length; k++) {
        pipes.push(await renderPipeline(list[k], `blade_render.wgsl (${label}class ${k})`,
          { topology: "triangle-strip", depth: depthStencil }));
      }
      return pipes;
    };
    this.bladePipes = await ribbons(shaders.blades, "");
    this.flatBladePipes = shaders.blades_flat ? await ribbons(shaders.blades_flat, "colour by, ") : this.bladePipes;
    // After the opaque grass, at the far depth with "less": only uncovered pixels are shaded.
    this.skyGround = await renderPipeline(shaders.sky_ground, "sky_ground.wgsl",
      { topology: "triangle-strip", depth: { format: this.depthFormat, depthWriteEnabled: false, depthCompare: "less" } });
    const blend = {
      color: { srcFactor: "src-alpha", dstFactor: "one-minus-src-alpha", operation: "add" },
      alpha: { srcFactor: "one", dstFactor: "one-minus-src-alpha", operation: "add" },
    };
    this.balls = await renderPipeline({ ...shaders.balls, vertex: "vs_ball", fragment: "fs_ball" }, "balls.wgsl",
      { topology: "triangle-list", depth: { format: this.depthFormat, depthWriteEnabled: false, depthCompare: "less" }, blend });
    this.occlusion = shaders.occlusion ? await this.buildOcclusionPipelines(shaders.occlusion, ribbons) : null;
    this.raster = shaders.compute_raster ? await this.buildRasterPipelines(shaders.compute_raster, depthStencil) : null;
    // Lines and points over the meadow (overlay.wgsl): a quad per item, `instances` items.
    this.overlays = [];
    for (const o of shaders.overlays || []) {
      const depth = { format: this.depthFormat, depthWriteEnabled: false, depthCompare: o.depth_test ? "less" : "always" };
      const pipe = await renderPipeline(o, `overlay.wgsl (${o.name})`, { topology: "triangle-list", depth });
      this.overlays.push({ ...pipe, instances: o.instances, onlyIf: o.only_if });
    }
  }

  // Whether a pass or overlay with this "only_if" runs now (no condition: always).
  active(condition) {
    if (!condition) return true;
    if (condition === "frozen") return this.model.get("frustum_lines").byteLength > 0;
    if (condition === "inspecting") return (this.model.get("inspected") || []).length > 0;
    if (condition === "compute_raster") return this.rasterOn();
    return false;
  }

  buildBuffers() {
    const device = this.device;
    const U = GPUBufferUsage;
    for (const b of this.ownBuffers || []) b.destroy();
    this.ownBuffers = [];
    const buffer = (size, usage, label) => {
      const b = device.createBuffer({ size: Math.max(16, Math.ceil(size / 4) * 4), usage, label });
      this.ownBuffers.push(b);
      return b;
    };
    const uniform = (trait, label) => buffer(this.model.get(trait).byteLength, U.UNIFORM | U.COPY_DST, label);
    const n = this.model.get("n_blades");
    const classes = this.lodSegments.length;
    const sizes = this.model.get("shaders").inspector_sizes;
    this.n = n;
    this.res = {
      s_blades: buffer(n * 64, U.STORAGE | U.COPY_SRC | U.COPY_DST, "blades"),
      s_collision: buffer(n * 4, U.STORAGE | U.COPY_SRC | U.COPY_DST, "collision"),
      s_args: buffer(classes * 16, U.STORAGE | U.INDIRECT | U.COPY_SRC | U.COPY_DST, "draw args"),
      s_visible: buffer(classes * n * 4, U.STORAGE, "visible"),
      s_culled: buffer(n * 4, U.STORAGE, "culled"),
      s_culled_args: buffer(16, U.STORAGE | U.INDIRECT | U.COPY_DST, "culled draw args"),
      s_bands: buffer(2 * classes * Math.max(this.model.get("shaders").bands || 1, 1) * 4, U.STORAGE, "distance bands"),
      u_sim: uniform("sim_uniform", "u_sim"),
      u_cull: uniform("cull_uniform", "u_cull"),
      u_material: uniform("material_uniform", "u_material"),
      u_sky_ground: uniform("sky_ground_uniform", "u_sky_ground"),
      u_balls: uniform("ball_uniform", "u_balls"),
      u_stdinfo: buffer(this.model.get("stdinfo_size"), U.UNIFORM | U.COPY_DST, "u_stdinfo"),
      u_wobject: buffer(128, U.UNIFORM | U.COPY_DST, "u_wobject"),
      s_colliders: buffer(this.model.get("collider_buffer_bytes")[0], U.STORAGE | U.COPY_DST, "colliders"),
      s_collider_grid: buffer(this.model.get("collider_buffer_bytes")[1], U.STORAGE | U.COPY_DST, "collider grid"),
      u_inspect: uniform("inspect_uniform", "u_inspect"),
      s_frustum: buffer(sizes.frustum, U.STORAGE | U.COPY_DST, "frustum lines"),
      s_segments: buffer(sizes.segments, U.STORAGE, "inspector lines"),
      s_points: buffer(sizes.points, U.STORAGE | U.COPY_SRC, "inspector points"),
      s_forces: buffer(sizes.forces, U.STORAGE | U.COPY_SRC, "inspector forces"),
    };
    this.res.s_balls = this.res.s_colliders;  // the balls are drawn from the colliders' buffer
    if (this.occlusion) this.buildOcclusionBuffers(buffer);
    if (this.raster) this.buildRasterBuffers(buffer);
    // The args of the first phase, then (with occlusion culling) the second's and the occluded
    // count, then (with the compute rasterizer) its counters.
    this.argsRead = buffer(classes * 16 + (this.occlusion ? 4 * this.occlusion.spec.args_words : 0)
      + (this.raster ? 4 * this.raster.spec.args_words : 0), U.MAP_READ | U.COPY_DST, "args readback");
    const identity = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];  // world_transform and its inverse
    device.queue.writeBuffer(this.res.u_wobject, 0, new Float32Array([...identity, ...identity]));
    this.uploadRestPose();
    for (const [name, trait] of UNIFORM_TRAITS) this.writeUniform(name, trait);
    this.writeFrustum();
    this.writeBalls();
    this.makeBindGroups();
  }

  makeBindGroups() {
    const group = (p) => this.device.createBindGroup({
      layout: p.layout,
      entries: p.shader.bindings.map((b) => {
        const buffer = this.res[b.resource || b.name];
        if (!buffer) throw new Error(`the browser engine has no resource named ${b.resource || b.name}`);
        return { binding: b.binding, resource: { buffer } };
      }),
    });
    // (the passes bound to a view size's buffers get theirs from rasterTarget)
    for (const p of [this.sim, ...this.computePasses.filter((q) => !q.sized), ...this.bladePipes,
      ...this.flatBladePipes, this.skyGround, this.balls, ...this.overlays]) p.group = group(p);
    if (this.occlusion) this.makeOcclusionBindGroups(group);
    if (this.raster) this.dropRasterTargets();
  }

  uploadRestPose() {
    const data = this.model.get("blade_data");
    const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
    this.device.queue.writeBuffer(this.res.s_blades, 0, bytes);
    this.device.queue.writeBuffer(this.res.s_collision, 0, new Float32Array(this.n));
    this.stepCount = 0;
    this.clock.reset(performance.now() / 1000);
  }

  // The ribbon pipelines for the current params.color_by (u_cull.color_by: 0 natural).
  ribbonPipes() {
    const off = this.model.get("shaders").color_by_offset;
    const cu = this.model.get("cull_uniform");
    const colorBy = off === undefined ? 1 : new DataView(cu.buffer, cu.byteOffset, cu.byteLength).getInt32(off, true);
    return colorBy === 0 ? this.bladePipes : this.flatBladePipes;
  }

  // Python's packed bytes into a uniform buffer, as they are.
  writeUniform(name, trait) {
    const data = this.model.get(trait);
    this.device.queue.writeBuffer(this.res[name], 0, new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  }

  // The frozen camera's frustum edges (Python's core.teaching.frustum_segments), when frozen.
  writeFrustum() {
    const data = this.model.get("frustum_lines");
    if (data.byteLength) this.device.queue.writeBuffer(this.res.s_frustum, 0, new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  }

  // The spheres and their grid, as Python built them (grasswidget.core.collider_grid).
  writeBalls() {
    for (const [name, trait] of [["s_colliders", "collider_spheres"], ["s_collider_grid", "collider_grid"]]) {
      const data = this.model.get(trait);
      if (data && data.byteLength) {
        this.device.queue.writeBuffer(this.res[name], 0, new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
      }
    }
    const grid = this.model.get("collider_grid");  // word 2: the number of spheres
    this.nBalls = grid && grid.byteLength >= 12 ? new DataView(grid.buffer, grid.byteOffset, grid.byteLength).getUint32(8, true) : 0;
  }

  // ---------------------------------------------------------------- simulation

  workgroups(items) {
    const groups = Math.max(1, Math.ceil(items / WORKGROUP));
    const x = Math.min(groups, 65535);
    return [x, Math.ceil(groups / x)];
  }

  // Exactly n fixed steps of dt, like GrassField.step (wind time (k dt) mod period).
  // Python's u_sim bytes with this dispatch's time0 (s) and steps.
  simUniformBytes(time0, steps) {
    const layout = this.model.get("sim_layout");
    const base = this.model.get("sim_uniform");
    const bytes = new Uint8Array(base.byteLength);
    bytes.set(new Uint8Array(base.buffer, base.byteOffset, base.byteLength));
    const view = new DataView(bytes.buffer);
    view.setFloat32(layout.time0[0], time0, true);
    view.setInt32(layout.steps[0], steps, true);
    return bytes;
  }

  // The wind time of step k: (k dt) mod wind_period (the clock's rules from Python).
  windTime(k) {
    const clock = this.rules().clock;
    const t = k * clock.dt;
    return clock.wind_period > 0 ? t % clock.wind_period : t;
  }

  // u_sim for "now": the current parameters at the time of the next step, no steps
  // (what the kernel's inspector writes before its pass: gpu.inspector.refresh_uniforms).
  writeSimNow() {
    this.device.queue.writeBuffer(this.res.u_sim, 0, this.simUniformBytes(this.windTime(this.stepCount), 0));
  }

  simulate(n) {
    if (n <= 0) return;
    const device = this.device;
    const perDispatch = Math.max(1, Math.floor(BLADE_STEPS_PER_DISPATCH / Math.max(this.n, 1)));
    const [gx, gy] = this.workgroups(this.n);
    let done = 0;
    while (done < n) {
      const chunk = Math.min(perDispatch, n - done);
      device.queue.writeBuffer(this.res.u_sim, 0, this.simUniformBytes(this.windTime(this.stepCount), chunk));
      const encoder = device.createCommandEncoder();
      const pass = encoder.beginComputePass();
      pass.setPipeline(this.sim.pipeline);
      pass.setBindGroup(0, this.sim.group);
      pass.dispatchWorkgroups(gx, gy);
      pass.end();
      device.queue.submit([encoder.finish()]);
      this.stepCount += chunk;
      done += chunk;
    }
  }

  // ---------------------------------------------------------------- drawing

  matrices(aspect) {
    const cam = this.camera();
    const world = cameraWorld(cam.position, cam.target);
    const view = invert4(world);
    const proj = perspective(cam.fov_deg, aspect, cam.near, cam.far);
    return { world, view, proj };
  }

  // The camera uniform (pygfx's StdInfo) at the offsets Python's layout gives.
  writeStdInfo(width, height) {
    const { world, view, proj } = this.matrices(width / height);
    const at = this.model.get("stdinfo_layout");
    const f = new Float32Array(this.model.get("stdinfo_size") / 4);
    const put = (name, values) => f.set(values, at[name][0] / 4);
    put("cam_transform", view); put("cam_transform_inv", world);
    put("projection_transform", proj); put("projection_transform_inv", invert4(proj));
    put("physical_size", [width, height]); put("logical_size", [width, height]);
    put("ndc_offset", [1, 1, 0, 0]);
    this.device.queue.writeBuffer(this.res.u_stdinfo, 0, f);
  }

  // Encode one frame of the current state into a colour view of (width, height): Python's
  // compute passes (culling) for this view's camera, then the draws. Submit before the next call
  // (the camera uniform is written now, for this encoder).
  encodeFrame(encoder, colorView, depthTexture, width, height) {
    this.writeStdInfo(width, height);
    const twoPhases = this.occlusionOn();
    const raster = this.rasterOn() ? this.rasterTarget(width, height) : null;
    const depthView = depthTexture.createView();
    const blades = this.workgroups(this.n);
    const pixels = this.workgroups(width * height);
    const cpass = encoder.beginComputePass();
    for (const p of this.computePasses) {
      if (!this.active(p.onlyIf)) continue;
      if (p.simNow) this.writeSimNow();
      cpass.setPipeline(p.pipeline);
      cpass.setBindGroup(0, p.sized ? raster.groups.get(p.name) : p.group);
      if (p.dispatch === "blades") cpass.dispatchWorkgroups(blades[0], blades[1]);
      else if (p.dispatch === "pixels") cpass.dispatchWorkgroups(pixels[0], pixels[1]);
      else cpass.dispatchWorkgroups(1);
    }
    cpass.end();
    const pass = encoder.beginRenderPass({
      colorAttachments: [{ view: colorView, loadOp: "clear", storeOp: "store", clearValue: { r: 0, g: 0, b: 0, a: 1 } }],
      depthStencilAttachment: { view: depthView, depthLoadOp: "clear", depthClearValue: 1,
        depthStoreOp: twoPhases ? "store" : "discard" },
    });
    this.ribbonPipes().forEach((p, k) => {
      if (p.shader.culled && twoPhases) return;  // the culled blades are listed by the second phase
      pass.setPipeline(p.pipeline);
      pass.setBindGroup(0, p.group);
      if (p.shader.culled) pass.drawIndirect(this.res.s_culled_args, 0);  // color_by "cull": the culled blades
      else pass.drawIndirect(this.res.s_args, 16 * k);
    });
    if (raster) this.encodeRasterResolve(pass, raster);
    pass.setPipeline(this.skyGround.pipeline);
    pass.setBindGroup(0, this.skyGround.group);
    pass.draw(4);
    if (twoPhases) {
      pass.end();
      this.encodeOcclusionSecondPhase(encoder, depthTexture, width, height, raster);
      const second = this.beginOcclusionDrawPass(encoder, colorView, depthView);
      if (raster) this.encodeRasterResolve(second, raster);
      this.encodeBalls(second);
      return;
    }
    this.encodeBalls(pass);
  }

  // The translucent collider balls (after every blade), then the pass ends.
  encodeBalls(pass) {
    const balls = this.nBalls || 0;
    if (balls > 0 && this.model.get("show_colliders")) {
      pass.setPipeline(this.balls.pipeline);
      pass.setBindGroup(0, this.balls.group);
      pass.draw(6 * 16 * 32, balls);
    }
    for (const o of this.overlays) {
      if (!this.active(o.onlyIf)) continue;
      pass.setPipeline(o.pipeline);
      pass.setBindGroup(0, o.group);
      pass.draw(6, o.instances);
    }
    pass.end();
  }

  depthFor(width, height) {
    // COPY_SRC: occlusion culling copies the depth into its pyramid.
    return this.device.createTexture({ size: [width, height], format: this.depthFormat,
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
  }

  scheduleFrame() {
    if (this.closed || this.raf || !this.visibleViews().length) return;
    this.raf = requestAnimationFrame((t) => { this.raf = null; this.frame(t); });
  }

  // One animation frame: the clock's steps (once, whatever the number of views), then every visible
  // view drawn. With no view visible nothing runs and no new frame is asked for: the engine rests
  // until visibilityChanged() finds a view in sight again.
  frame(now) {
    if (!this.ready || this.closed) return;
    const shown = this.visibleViews();
    if (!shown.length) { this.rest(); return; }
    if (this.resting) {
      // Back in sight: frames/s is measured from now, not over the time at rest.
      this.resting = false;
      this.statsTime = performance.now();
      this.statsFrames = this.frames;
    }
    this.scheduleFrame();
    if (this.inFlight >= MAX_FRAMES_IN_FLIGHT) return;
    const t0 = performance.now();
    try {
      const rules = this.rules().clock;
      this.clock.maxSteps = rules.max_steps_per_frame;
      if (this.model.get("playing")) {
        this.clock.start(now / 1000);
        const n = this.clock.frameSteps(now / 1000, rules.dt, this.model.get("time_scale"));
        if (n > 0) { this.onSteps(n); this.simulate(n); }
      } else {
        this.clock.stop();
      }
      const device = this.device;
      let first = true;
      for (const view of shown) {
        if (!view.context) continue;
        const { color, depth, w, h } = view.targets();
        const encoder = device.createCommandEncoder();
        this.encodeFrame(encoder, color, depth, w, h);
        const readArgs = first && !this.argsReadPending && performance.now() - (this.lastArgsRead || 0) > this.statsInterval() / 2;
        if (readArgs) this.encodeArgsRead(encoder);
        device.queue.submit([encoder.finish()]);
        if (readArgs) this.readArgs();
        if (first) this.frameSize = [w, h];
        first = false;
        view.countFrame();
      }
      this.inFlight += 1;
      device.queue.onSubmittedWorkDone().then(() => {
        this.inFlight -= 1;
        this.frames += 1;
        if (!this.timing.first_frame) this.timing.first_frame = performance.now();
        this.lastFrameMs = performance.now() - t0;
      }, () => { this.inFlight = 0; });
    } catch (err) {
      this.report("error", `browser frame failed: ${err.message || err}`);
    }
    this.maybeSendStats();
  }

  onSteps(n) {
    this.pendingSteps = (this.pendingSteps || 0) + n;
    if (this.model.get("report_steps")) {
      // Tell Python how much simulated time passed (it moves a rolling ball).
      this.rollSteps = (this.rollSteps || 0) + n;
      const now = performance.now();
      if (!this.lastRollReport || now - this.lastRollReport > 60) {
        this.report("steps", "", { steps: this.rollSteps });
        this.rollSteps = 0;
        this.lastRollReport = now;
      }
    }
  }

  readArgs() {
    const buf = this.argsRead;
    this.argsReadPending = true;
    this.lastArgsRead = performance.now();
    buf.mapAsync(GPUMapMode.READ).then(() => {
      const a = new Uint32Array(buf.getMappedRange().slice(0));
      buf.unmap();
      const classes = this.lodSegments.length;
      const second = this.occlusion ? a.subarray(4 * classes) : null;
      // Both occlusion phases' draws; occluded null while occlusion culling is off (as the kernel's stats).
      this.visible = this.lodSegments.map((_, k) => a[4 * k + 1] + (second ? second[4 * k + 1] : 0));
      this.occluded = second && this.occlusionOn() ? second[4 * classes] : null;
      // Blades drawn by the compute rasterizer (both phases); 0 while it is off (as the kernel's stats).
      const at = 4 * classes + (this.occlusion ? this.occlusion.spec.args_words : 0);
      this.rastered = this.raster ? (this.rasterOn() ? a[at] : 0) : null;
      this.visibleAt = performance.now();
      this.argsReadPending = false;
    }, () => { this.argsReadPending = false; });
  }

  // Milliseconds between stats messages: Python's stats_interval_ms (the lab bench asks for 200
  // while a chart is shown), else STATS_INTERVAL_MS.
  statsInterval() {
    return this.model.get("stats_interval_ms") || STATS_INTERVAL_MS;
  }

  maybeSendStats() {
    const now = performance.now();
    if (now - this.statsTime < this.statsInterval()) return;
    const fps = ((this.frames - this.statsFrames) * 1000) / (now - this.statsTime);
    this.statsFrames = this.frames;
    this.statsTime = now;
    const steps = this.pendingSteps || 0;
    this.pendingSteps = 0;
    this.report("stats", "", {
      fps, visible: this.visible, occluded: this.occluded === undefined ? null : this.occluded,
      rastered: this.rastered === undefined ? null : this.rastered, step_count: this.stepCount, steps, frame_ms: this.lastFrameMs,
      frame_size: this.frameSize || null, adapter: this.adapterText, views: this.views.size,
    });
  }

  // ---------------------------------------------------------------- occlusion culling
  // Python's shaders.occlusion (grasswidget.browser.wgsl.BrowserShaders.occlusion) executed: the
  // pyramid's levels, the second culling phase and its draws. Kept apart from the rest of the
  // engine (buildPipelines, buildBuffers, makeBindGroups and encodeFrame each call in here once).

  // The pipelines: one hzb_build.wgsl per pyramid level, the second phase's cull.wgsl, the
  // second phase's ribbons (lists from the end; natural and colour-by sets).
  async buildOcclusionPipelines(spec, ribbons) {
    const levels = await Promise.all(spec.hzb_levels.map((sh, k) => this.computePipeline(sh, `hzb_build.wgsl (level ${k + 1})`)));
    const cull = await this.computePipeline(spec.cull, "cull.wgsl (occlusion, second phase)");
    const blades = await ribbons(spec.blades, "occlusion second phase, ");
    const flatBlades = await ribbons(spec.blades_flat, "occlusion second phase, colour by, ");
    return { spec, levels, cull, blades, flatBlades, targets: new Map() };
  }

  // u_cull.occlusion_phase of Python's bytes (frame_data.cull_uniform_values): 1 = two phases.
  occlusionOn() {
    if (!this.occlusion) return false;
    const cu = this.model.get("cull_uniform");
    const at = this.occlusion.spec.phase_offset;
    if (!cu || cu.byteLength < at + 4) return false;
    return new DataView(cu.buffer, cu.byteOffset, cu.byteLength).getInt32(at, true) === 1;
  }

  // s_occlusion_flags (one bit per blade, whole workgroups of words, all ones: every blade seen)
  // and s_occlusion_args (the second phase's draw args, then the occluded count).
  buildOcclusionBuffers(buffer) {
    const U = GPUBufferUsage;
    const spec = this.occlusion.spec;
    const [gx, gy] = this.workgroups(this.n);
    const words = gx * gy * spec.flag_words_per_workgroup;
    this.res.s_occlusion_flags = buffer(words * 4, U.STORAGE | U.COPY_DST, "occlusion flags");
    this.device.queue.writeBuffer(this.res.s_occlusion_flags, 0, new Uint32Array(words).fill(0xFFFFFFFF));
    this.res.s_occlusion_args = buffer(spec.args_words * 4, U.STORAGE | U.INDIRECT | U.COPY_SRC | U.COPY_DST,
      "occlusion draw args");
  }

  // Bind groups of the second phase's draws; the per-size ones (pyramid) are made again on demand.
  makeOcclusionBindGroups(group) {
    const o = this.occlusion;
    for (const p of [...o.blades, ...o.flatBlades]) p.group = group(p);
    this.dropOcclusionTargets();
  }

  dropOcclusionTargets() {
    for (const t of this.occlusion.targets.values()) { t.hzb.destroy(); t.table.destroy(); }
    this.occlusion.targets.clear();
  }

  // The pyramid of a (width, height) view: its buffer (reference.hzb_layout's layout), its level
  // table, the bind groups that use them. A few sizes are kept (views, snapshots).
  occlusionTarget(width, height) {
    const o = this.occlusion;
    const key = `${width}x${height}`;
    let t = o.targets.get(key);
    if (t) { o.targets.delete(key); o.targets.set(key, t); return t; }
    const spec = o.spec;
    const layout = hzbLayout(width, height, spec.row_align);
    if (layout.length > spec.max_levels) {
      throw new Error(`occlusion culling supports views up to ${2 ** (spec.max_levels - 1)} pixels wide and high; got ${width} x ${height}`);
    }
    const U = GPUBufferUsage;
    const last = layout[layout.length - 1];
    const hzb = this.device.createBuffer({ size: 4 * (last[0] + last[1] * last[2]), usage: U.STORAGE | U.COPY_DST, label: "hzb" });
    const words = new Uint32Array(4 * (spec.max_levels + 1));
    words.set([layout.length, width, height, 0]);
    layout.forEach((level, k) => words.set(level, 4 * (k + 1)));
    const table = this.device.createBuffer({ size: words.byteLength, usage: U.STORAGE | U.COPY_DST, label: "hzb levels" });
    this.device.queue.writeBuffer(table, 0, words);
    const res = { ...this.res, s_hzb: hzb, s_hzb_levels: table };
    const group = (p) => this.device.createBindGroup({
      layout: p.layout,
      entries: p.shader.bindings.map((b) => ({ binding: b.binding, resource: { buffer: res[b.resource || b.name] } })),
    });
    t = { layout, hzb, table, levelGroups: o.levels.slice(0, layout.length - 1).map(group), cullGroup: group(o.cull) };
    o.targets.set(key, t);
    while (o.targets.size > 3) {
      const [oldKey, old] = o.targets.entries().next().value;
      old.hzb.destroy(); old.table.destroy();
      o.targets.delete(oldKey);
    }
    return t;
  }

  // Between the phases: the depth into the pyramid's level 0, the further levels, the second cull.
  encodeOcclusionSecondPhase(encoder, depthTexture, width, height, raster) {
    const o = this.occlusion;
    const t = this.occlusionTarget(width, height);
    encoder.copyTextureToBuffer({ texture: depthTexture, aspect: "depth-only" },
      { buffer: t.hzb, bytesPerRow: 4 * t.layout[0][3], rowsPerImage: height }, [width, height]);
    const cpass = encoder.beginComputePass();
    t.levelGroups.forEach((g, k) => {
      const [, w, h] = t.layout[k + 1];
      cpass.setPipeline(o.levels[k].pipeline);
      cpass.setBindGroup(0, g);
      cpass.dispatchWorkgroups(Math.ceil(w / 8), Math.ceil(h / 8));
    });
    const blades = this.workgroups(this.n);
    cpass.setPipeline(o.cull.pipeline);
    cpass.setBindGroup(0, t.cullGroup);
    cpass.dispatchWorkgroups(blades[0], blades[1]);
    if (raster) {  // the thin blades the second phase listed, walked into the same per-pixel words
      for (const name of ["second_depth", "second_payload"]) {
        cpass.setPipeline(this.raster[name].pipeline);
        cpass.setBindGroup(0, raster.groups.get(name));
        cpass.dispatchWorkgroups(blades[0], blades[1]);
      }
    }
    cpass.end();
  }

  // The second phase's draws over the first's picture (colour and depth loaded), then the culled
  // blades (colour by cull: every test's, occlusion included); returns the pass (balls follow).
  beginOcclusionDrawPass(encoder, colorView, depthView) {
    const o = this.occlusion;
    const pass = encoder.beginRenderPass({
      colorAttachments: [{ view: colorView, loadOp: "load", storeOp: "store" }],
      depthStencilAttachment: { view: depthView, depthLoadOp: "load", depthStoreOp: "discard" },
    });
    const flat = this.ribbonPipes() !== this.bladePipes;
    (flat ? o.flatBlades : o.blades).forEach((p, k) => {
      pass.setPipeline(p.pipeline);
      pass.setBindGroup(0, p.group);
      pass.drawIndirect(this.res.s_occlusion_args, 16 * k);
    });
    const culled = flat ? this.flatBladePipes.find((p) => p.shader.culled) : null;
    if (culled) {
      pass.setPipeline(culled.pipeline);
      pass.setBindGroup(0, culled.group);
      pass.drawIndirect(this.res.s_culled_args, 0);
    }
    return pass;
  }

  // The stats' readback: the first phase's args, then the second's with the occluded count.
  encodeArgsRead(encoder) {
    const first = 16 * this.lodSegments.length;
    encoder.copyBufferToBuffer(this.res.s_args, 0, this.argsRead, 0, first);
    if (this.occlusion) {
      encoder.copyBufferToBuffer(this.res.s_occlusion_args, 0, this.argsRead, first, 4 * this.occlusion.spec.args_words);
    }
    if (this.raster) {
      const at = first + (this.occlusion ? 4 * this.occlusion.spec.args_words : 0);
      encoder.copyBufferToBuffer(this.res.s_raster_args, 0, this.argsRead, at, 4 * this.raster.spec.args_words);
    }
  }

  // ---------------------------------------------------------------- compute rasterizer
  // Python's shaders.compute_raster (grasswidget.browser.wgsl.BrowserShaders.compute_raster)
  // executed: per view size, the per-pixel depth and payload words and the bind groups of the
  // passes that use them; the resolve draw. The clear and the walks are compute passes of
  // shaders.compute_passes (only_if "compute_raster", "sized").

  async buildRasterPipelines(spec, depthStencil) {
    const second_depth = await this.computePipeline(spec.second_depth, "raster.wgsl (depth, occlusion second phase)");
    const second_payload = await this.computePipeline(spec.second_payload, "raster.wgsl (payload, occlusion second phase)");
    const resolve = await this.renderPipeline(spec.resolve, "raster_resolve.wgsl", { topology: "triangle-strip", depth: depthStencil });
    const resolveFlat = await this.renderPipeline(spec.resolve_flat, "raster_resolve.wgsl (colour by)",
      { topology: "triangle-strip", depth: depthStencil });
    return { spec, second_depth, second_payload, resolve, resolveFlat, targets: new Map() };
  }

  // u_cull.compute_raster of Python's bytes (frame_data.compute_raster_values): 1 = on.
  rasterOn() {
    if (!this.raster) return false;
    const cu = this.model.get("cull_uniform");
    const at = this.raster.spec.switch_offset;
    if (!cu || cu.byteLength < at + 4) return false;
    return new DataView(cu.buffer, cu.byteOffset, cu.byteLength).getInt32(at, true) === 1;
  }

  // s_raster (the listed blades) and s_raster_args (counters, read by the stats).
  buildRasterBuffers(buffer) {
    const U = GPUBufferUsage;
    this.res.s_raster = buffer(this.n * 4, U.STORAGE, "compute raster list");
    this.res.s_raster_args = buffer(4 * this.raster.spec.args_words, U.STORAGE | U.COPY_SRC, "compute raster counters");
  }

  dropRasterTargets() {
    for (const t of this.raster.targets.values()) { t.depth.destroy(); t.payload.destroy(); }
    this.raster.targets.clear();
  }

  // The per-pixel words of a (width, height) view and the bind groups that use them; this frame's
  // render size written into u_cull (cull.wgsl lists thin blades only in renders of that size).
  // A few sizes are kept (views, snapshots).
  rasterTarget(width, height) {
    const r = this.raster;
    const size = new Float32Array([width]);
    this.device.queue.writeBuffer(this.res.u_cull, r.spec.width_offset, size);
    this.device.queue.writeBuffer(this.res.u_cull, r.spec.height_offset, new Float32Array([height]));
    const key = `${width}x${height}`;
    let t = r.targets.get(key);
    if (t) { r.targets.delete(key); r.targets.set(key, t); return t; }
    const U = GPUBufferUsage;
    const bytes = 4 * width * height;
    const depth = this.device.createBuffer({ size: bytes, usage: U.STORAGE, label: "compute raster depth" });
    const payload = this.device.createBuffer({ size: bytes, usage: U.STORAGE, label: "compute raster payload" });
    const res = { ...this.res, s_raster_depth: depth, s_raster_payload: payload };
    const group = (p) => this.device.createBindGroup({
      layout: p.layout,
      entries: p.shader.bindings.map((b) => ({ binding: b.binding, resource: { buffer: res[b.resource || b.name] } })),
    });
    const groups = new Map();
    for (const p of this.computePasses.filter((q) => q.sized)) groups.set(p.name, group(p));
    for (const name of ["second_depth", "second_payload"]) groups.set(name, group(r[name]));
    groups.set("resolve", group(r.resolve));
    groups.set("resolveFlat", group(r.resolveFlat));
    t = { depth, payload, groups };
    r.targets.set(key, t);
    while (r.targets.size > 3) {
      const [oldKey, old] = r.targets.entries().next().value;
      old.depth.destroy(); old.payload.destroy();
      r.targets.delete(oldKey);
    }
    return t;
  }

  // The resolve: one full-screen draw writing the compute-drawn pixels' colour and depth (the
  // colour-by views' variant while color_by is not natural, as the ribbons).
  encodeRasterResolve(pass, target) {
    const flat = this.ribbonPipes() !== this.bladePipes;
    const p = flat ? this.raster.resolveFlat : this.raster.resolve;
    pass.setPipeline(p.pipeline);
    pass.setBindGroup(0, target.groups.get(flat ? "resolveFlat" : "resolve"));
    pass.draw(4);
  }

  // ---------------------------------------------------------------- requests from Python

  async onMessage(msg, buffers) {
    if (!this.ready) {
      this.queue.push([msg, buffers]);
      return;
    }
    try {
      switch (msg.type) {
        case "step": this.simulate(msg.n); break;
        case "reset": this.uploadRestPose(); break;
        case "read_state": await this.readState(msg.id); break;
        case "read_inspected": await this.readInspected(msg); break;
        case "sync": this.report("synced", "", { id: msg.id }); break;
        case "snapshot": await this.snapshot(msg); break;
        case "compile_simulate": await this.compileSimulate(msg); break;
        case "lose_device": this.expectLoss = true; this.device.destroy(); break;
        default: break;
      }
    } catch (err) {
      this.report("error", `browser engine: ${msg.type} failed: ${err.message || err}`, { id: msg.id });
    }
  }

  async readState(id) {
    const device = this.device;
    const U = GPUBufferUsage;
    const a = device.createBuffer({ size: this.res.s_blades.size, usage: U.MAP_READ | U.COPY_DST });
    const b = device.createBuffer({ size: this.res.s_collision.size, usage: U.MAP_READ | U.COPY_DST });
    const encoder = device.createCommandEncoder();
    encoder.copyBufferToBuffer(this.res.s_blades, 0, a, 0, a.size);
    encoder.copyBufferToBuffer(this.res.s_collision, 0, b, 0, b.size);
    device.queue.submit([encoder.finish()]);
    const steps = this.stepCount;
    await Promise.all([a.mapAsync(GPUMapMode.READ), b.mapAsync(GPUMapMode.READ)]);
    const blades = a.getMappedRange().slice(0, this.n * 64);
    const collision = b.getMappedRange().slice(0, this.n * 4);
    a.destroy(); b.destroy();
    this.model.send({ type: "state", id, step_count: steps, n: this.n }, undefined, [blades, collision]);
  }

  // The inspected blades' forces (vec4 each) and control points (3 floats each), computed now
  // by the inspector's passes for the current state and parameters (as gpu.inspector.BladeInspector.read).
  async readInspected(msg) {
    const device = this.device;
    const id = msg.id;
    const n = (this.model.get("inspected") || []).length;
    const passes = this.computePasses.filter((p) => p.onlyIf === "inspecting");
    const forcesBytes = this.res.s_forces.size / 64 * n, pointsBytes = 36 * n;
    const U = GPUBufferUsage;
    const a = device.createBuffer({ size: Math.max(16, forcesBytes), usage: U.MAP_READ | U.COPY_DST });
    const b = device.createBuffer({ size: Math.max(16, Math.ceil(pointsBytes / 4) * 4 + 4), usage: U.MAP_READ | U.COPY_DST });
    const encoder = device.createCommandEncoder();
    if (n > 0) {
      const cpass = encoder.beginComputePass();
      for (const p of passes) {
        if (p.simNow) this.writeSimNow();
        cpass.setPipeline(p.pipeline);
        cpass.setBindGroup(0, p.group);
        cpass.dispatchWorkgroups(1);
      }
      cpass.end();
      encoder.copyBufferToBuffer(this.res.s_forces, 0, a, 0, forcesBytes);
      encoder.copyBufferToBuffer(this.res.s_points, 0, b, 0, Math.ceil(pointsBytes / 4) * 4);
    }
    device.queue.submit([encoder.finish()]);
    await Promise.all([a.mapAsync(GPUMapMode.READ), b.mapAsync(GPUMapMode.READ)]);
    const forces = a.getMappedRange().slice(0, forcesBytes);
    const points = b.getMappedRange().slice(0, pointsBytes);
    a.destroy(); b.destroy();
    this.model.send({ type: "inspected", id, n, step_count: this.stepCount }, undefined, [forces, points]);
  }

  // A picture of the current state at msg.width x msg.height, rendered msg.filter.factor
  // times larger and filtered down (Python's export_filter; factor 1 when absent or when
  // the larger picture would exceed the device's texture limit).
  async snapshot(msg) {
    const device = this.device;
    const w = msg.width, h = msg.height;
    let filter = msg.filter || { factor: 1, first: 0, weights: [1] };
    if (Math.max(w, h) * filter.factor > device.limits.maxTextureDimension2D) filter = { factor: 1, first: 0, weights: [1] };
    const sw = w * filter.factor, sh = h * filter.factor;
    const color = device.createTexture({ size: [sw, sh], format: this.format,
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
    const depth = this.depthFor(sw, sh);
    const row = Math.ceil((sw * 4) / 256) * 256;
    const out = device.createBuffer({ size: row * sh, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
    const encoder = device.createCommandEncoder();
    this.encodeFrame(encoder, color.createView(), depth, sw, sh);
    encoder.copyTextureToBuffer({ texture: color }, { buffer: out, bytesPerRow: row }, [sw, sh]);
    device.queue.submit([encoder.finish()]);
    await out.mapAsync(GPUMapMode.READ);
    const src = new Uint8Array(out.getMappedRange());
    const bgra = this.format.startsWith("bgra");
    let rgba;
    if (filter.factor === 1) {
      rgba = new Uint8Array(w * h * 4);
      for (let y = 0; y < h; y++) {
        const s = y * row, d = y * w * 4;
        for (let x = 0; x < w; x++) {
          const i = s + 4 * x, j = d + 4 * x;
          rgba[j] = src[i + (bgra ? 2 : 0)];
          rgba[j + 1] = src[i + 1];
          rgba[j + 2] = src[i + (bgra ? 0 : 2)];
          rgba[j + 3] = 255;
        }
      }
    } else {
      rgba = downsample(src, w, h, row, bgra, filter);
    }
    out.unmap(); out.destroy(); color.destroy(); depth.destroy();
    this.model.send({ type: "snapshot", id: msg.id, width: w, height: h, supersample: filter.factor }, undefined,
                    [rgba.buffer]);
  }

  async compileSimulate(msg) {
    try {
      const sim = await this.computePipeline(msg.shader, "simulate.wgsl");
      // Compute passes that compile the same wind (the inspector): all compiled before any is swapped in.
      const passes = [];
      for (const [name, shader] of Object.entries(msg.passes || {})) {
        for (const p of this.computePasses.filter((q) => q.name === name)) {
          passes.push([p, await this.computePipeline(shader, p.label)]);
        }
      }
      this.sim = sim;
      for (const [p, pipe] of passes) Object.assign(p, pipe);
      this.makeBindGroups();
      this.report("compiled", "", { id: msg.id, ok: true });
    } catch (err) {
      // The old simulation pipeline stays in force.
      this.report("compiled", err.message, { id: msg.id, ok: false, messages: err.messages || [] });
    }
  }

  // ---------------------------------------------------------------- trait changes

  onChange(name) {
    if (name === "width" || name === "height" || name === "pixel_ratio") {
      for (const v of this.views) v.resize();
      return;
    }
    if (!this.ready) return;
    try {
      const uniform = UNIFORM_TRAITS.find(([, trait]) => trait === name);
      if (uniform) this.writeUniform(uniform[0], uniform[1]);
      else if (name === "collider_spheres" || name === "collider_grid") this.writeBalls();
      else if (name === "frustum_lines") this.writeFrustum();
      else if (name === "blade_data") this.buildBuffers();
    } catch (err) {
      this.report("error", `browser engine: applying ${name} failed: ${err.message || err}`);
    }
  }

  close() {
    this.closed = true;
    if (this.raf) cancelAnimationFrame(this.raf);
    document.removeEventListener("visibilitychange", this.onPageVisibility);
    this.model.off("msg:custom", this.onMsg);
    for (const [name, fn] of this.listeners) this.model.off(`change:${name}`, fn);
    for (const v of [...this.views]) this.removeView(v);
    if (this.device) { const d = this.device; this.device = null; d.destroy(); }
  }
}

// Uniform buffers filled with Python's packed bytes: [buffer name, trait].
const UNIFORM_TRAITS = [
  ["u_cull", "cull_uniform"], ["u_material", "material_uniform"], ["u_sky_ground", "sky_ground_uniform"],
  ["u_balls", "ball_uniform"], ["u_inspect", "inspect_uniform"],
];

// engine_key -> GrassEngine, for the whole page (the module is loaded once per page).
const ENGINES = (globalThis.__grasswidgetEngines = globalThis.__grasswidgetEngines || new Map());

function engineFor(model) {
  const key = model.get("engine_key");
  let engine = ENGINES.get(key);
  if (!engine || engine.closed) {
    engine = new GrassEngine(model);
    ENGINES.set(key, engine);
  }
  return engine;
}

export default {
  // Once per widget model: its one engine (the GPU starts when a view first shows it).
  initialize({ model }) {
    const engine = engineFor(model);
    return () => {
      engine.close();
      if (ENGINES.get(model.get("engine_key")) === engine) ENGINES.delete(model.get("engine_key"));
    };
  },
  // Once per display of the widget: one more view of the same engine.
  render({ model, el }) {
    const engine = engineFor(model);
    const view = new GrassView(engine, model, el);
    engine.addView(view);
    return () => engine.removeView(view);
  },
};
