// grasswidget's browser engine: the project's WGSL simulation, culling and
// ribbons, run in the notebook's browser with WebGPU (an anywidget ES module;
// shipped inside the wheel, nothing is fetched at run time).
//
// Python (grasswidget/browser/view.py) sends:
//   traits   blade_data (rest pose, N x 64 bytes), n_blades, shaders (WGSL text +
//            binding maps, rendered from the project's files), sim_uniform /
//            cull_uniform / material_uniform (packed structs), sim_layout
//            (offsets of steps/time0), clock ({dt, wind_period}), playing,
//            time_scale, camera ({position, target, fov_deg, near, far}),
//            collider_spheres / collider_grid (the colliders and their grid, bytes;
//            grasswidget.core.collider_grid), scene_style, width, height.
//   messages step {n}, reset, read_state {id}, snapshot {id, width, height},
//            compile_simulate {id, shader}, lose_device (tests).
// The browser answers with gpu_status (a trait), stats, state, snapshot,
// compiled, error and device_lost messages. Fixed steps: step(n) runs exactly n
// steps of dt; playing follows the wall clock in whole steps of dt.

const MAX_STEPS_PER_FRAME = 240;
// Playing follows the wall clock down to 15 frames/s; a slower frame advances
// 1/15 s of simulated time (slow motion) instead of taking ever more steps.
const MAX_FRAME_TIME = 1 / 15;
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

// ------------------------------------------------------------------ the engine

class GrassEngine {
  constructor(model, el) {
    this.model = model;
    this.el = el;
    this.queue = [];          // messages that arrived before the device was ready
    this.ready = false;
    this.closed = false;
    this.device = null;
    this.stepCount = 0;
    this.accumulator = 0;
    this.lastTime = null;
    this.inFlight = 0;
    this.frames = 0;          // frames whose GPU work completed
    this.statsFrames = 0;
    this.statsTime = performance.now();
    this.visible = null;      // per LOD class, from the last args readback
    this.argsReadPending = false;
    this.lastFrameMs = null;
    this.handlers = [];
    this.expectLoss = false;
    this.recoveries = 0;
    // Start-up milestones (performance.now() ms), read by benchmarks.
    this.timing = { created: performance.now() };
    this.buildDom();
  }

  // ---------------------------------------------------------------- DOM and input

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
    this.note.textContent = "starting WebGPU…";
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
    this.depth = null;
  }

  camera() { return this.model.get("camera"); }

  setCamera(cam, sync) {
    this.model.set("camera", cam);
    const now = performance.now();
    if (sync || !this.lastCamSync || now - this.lastCamSync > 100) {
      this.model.save_changes();
      this.lastCamSync = now;
    }
  }

  pointerNdc(e) {
    const r = this.canvas.getBoundingClientRect();
    return [((e.clientX - r.left) / r.width) * 2 - 1, 1 - ((e.clientY - r.top) / r.height) * 2];
  }

  // Where the view ray through the pointer meets the ground plane, or null (sky).
  groundPoint(e) {
    const [x, y] = this.pointerNdc(e);
    const { view, proj } = this.matrices(this.canvas.width / this.canvas.height);
    const inv = invert4(mul4(proj, view));
    const unproject = (z) => {
      const p = [0, 1, 2, 3].map((r) => inv[r] * x + inv[4 + r] * y + inv[8 + r] * z + inv[12 + r]);
      return [p[0] / p[3], p[1] / p[3], p[2] / p[3]];
    };
    const a = unproject(0), b = unproject(1);
    const gy = (this.model.get("scene_style").ground_center || [0, 0, 0])[1] || 0;
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
    this.drag = { x: e.clientX, y: e.clientY, button: e.button, ball: e.shiftKey && e.button === 0 };
    if (this.drag.ball) this.sendBall(e, "down");
  }

  onPointerMove(e) {
    const d = this.drag;
    if (!d) return;
    const dx = e.clientX - d.x, dy = e.clientY - d.y;
    d.x = e.clientX; d.y = e.clientY;
    if (d.ball) { this.sendBall(e, "move"); return; }
    const cam = this.camera();
    const target = cam.target, pos = cam.position;
    let off = sub(pos, target);
    if (d.button === 2 || e.ctrlKey) {  // pan: move target and camera in the view plane
      const world = cameraWorld(pos, target);
      const dist = Math.hypot(...off);
      const k = (2 * dist * Math.tan((cam.fov_deg * Math.PI) / 360)) / this.canvas.clientHeight;
      const right = [world[0], world[1], world[2]], up = [world[4], world[5], world[6]];
      const move = add(scale(right, -dx * k), scale(up, dy * k));
      this.setCamera({ ...cam, position: add(pos, move), target: add(target, move) }, false);
      return;
    }
    const r = Math.hypot(...off);
    let az = Math.atan2(off[0], off[2]);
    let el = Math.asin(Math.max(-1, Math.min(1, off[1] / r)));
    az -= dx * 0.008;
    el = Math.max(0.02, Math.min(1.45, el + dy * 0.008));  // stay above the ground, short of the pole
    off = [r * Math.cos(el) * Math.sin(az), r * Math.sin(el), r * Math.cos(el) * Math.cos(az)];
    this.setCamera({ ...cam, position: add(target, off) }, false);
  }

  onPointerUp(e) {
    const d = this.drag;
    this.drag = null;
    if (!d) return;
    if (d.ball) this.sendBall(e, "up");
    else this.setCamera({ ...this.camera() }, true);
  }

  onWheel(e) {
    e.preventDefault();
    const cam = this.camera();
    const off = sub(cam.position, cam.target);
    const r = Math.hypot(...off);
    const k = Math.exp(Math.max(-0.5, Math.min(0.5, e.deltaY * 0.001)));
    const rNew = Math.max(0.5, Math.min(0.8 * cam.far, r * k));  // zoom range: near the target .. inside the far plane
    this.setCamera({ ...cam, position: add(cam.target, scale(off, rNew / r)) }, true);
  }

  onKey(e) {
    if (e.ctrlKey || e.altKey || e.metaKey) return;
    if (e.key === " ") {
      e.preventDefault();
      this.model.set("playing", !this.model.get("playing"));
      this.model.save_changes();
    } else if (e.key === "s") {
      this.model.send({ type: "key", key: "s" });
    } else if (e.key === "r") {
      this.model.send({ type: "key", key: "r" });
    }
  }

  sendBall(e, phase) {
    const hit = this.groundPoint(e);
    if (hit) this.model.send({ type: "ball", phase, x: hit[0], z: hit[1] });
  }

  // ---------------------------------------------------------------- start-up

  status(state, detail) {
    this.model.set("gpu_status", { state, detail: detail || "" });
    this.model.save_changes();
  }

  async start() {
    try {
      if (!navigator.gpu) {
        this.note.textContent = "WebGPU is not available in this browser";
        this.status("unavailable", "navigator.gpu is missing");
        return;
      }
      const adapter = await navigator.gpu.requestAdapter();
      if (!adapter) {
        this.note.textContent = "WebGPU is not available in this browser";
        this.status("unavailable", "requestAdapter() gave null");
        return;
      }
      const limits = {};
      for (const k of ["maxStorageBufferBindingSize", "maxBufferSize"]) limits[k] = adapter.limits[k];
      const device = await adapter.requestDevice({ requiredLimits: limits });
      if (this.closed) { device.destroy(); return; }
      const info = adapter.info || {};
      this.adapterText = [info.vendor, info.architecture, info.description].filter(Boolean).join(" ") || "WebGPU adapter";
      this.device = device;
      this.adapter = adapter;  // keep it referenced: Chromium rejects queue promises once the adapter is collected
      device.lost.then((lost) => this.onDeviceLost(device, lost));
      device.onuncapturederror = (ev) => this.report("error", `WebGPU error: ${ev.error.message}`);
      this.context = this.canvas.getContext("webgpu");
      this.format = navigator.gpu.getPreferredCanvasFormat();
      this.context.configure({ device, format: this.format, alphaMode: "opaque" });
      this.timing.device = performance.now();
      await this.buildPipelines();
      this.timing.pipelines = performance.now();
      this.buildBuffers();
      this.timing.buffers = performance.now();
      this.note.textContent = "";
      this.ready = true;
      this.status("ok", this.adapterText);
      const pending = this.queue;
      this.queue = [];
      for (const [msg, buffers] of pending) await this.onMessage(msg, buffers);
      this.scheduleFrame();
    } catch (err) {
      this.note.textContent = `WebGPU start failed: ${err.message || err}`;
      this.status("unavailable", `start failed: ${err.message || err}`);
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

  async buildPipelines() {
    const device = this.device;
    const shaders = this.model.get("shaders");
    this.lodSegments = shaders.lod_segments;
    this.sim = await this.computePipeline(shaders.simulate, "simulate.wgsl");
    this.resetArgs = await this.computePipeline(shaders.reset_args, "reset_args.wgsl");
    this.cull = await this.computePipeline(shaders.cull, "cull.wgsl");
    // Draw order by distance band (nearest first): count, prefix, then the cull above scatters.
    this.cullCount = shaders.cull_count ? await this.computePipeline(shaders.cull_count, "cull.wgsl (count)") : null;
    this.prefixBands = shaders.prefix_bands ? await this.computePipeline(shaders.prefix_bands, "prefix_bands.wgsl") : null;
    const depthStencil = { format: "depth24plus", depthWriteEnabled: true, depthCompare: "less" };
    // Two sets of ribbon pipelines: the natural view's, and the colour-by views' (flat colours and
    // the culled blades' draw), which cost GPU draw time and are only used while color_by shows them.
    const ribbons = async (list, label) => {
      const pipes = [];
      for (let k = 0; k < list.length; k++) {
        const shader = list[k];
        const module = await this.compile(shader, `blade_render.wgsl (${label}class ${k})`);
        const layout = this.layoutFor(shader, GPUShaderStage.VERTEX | GPUShaderStage.FRAGMENT);
        const pipeline = await device.createRenderPipelineAsync({
          layout: device.createPipelineLayout({ bindGroupLayouts: [layout] }),
          vertex: { module, entryPoint: "vs_main" },
          fragment: { module, entryPoint: "fs_main", targets: [{ format: this.format }] },
          primitive: { topology: "triangle-strip", cullMode: "none" },
          depthStencil,
        });
        pipes.push({ pipeline, layout, shader });
      }
      return pipes;
    };
    this.bladePipes = await ribbons(shaders.blades, "");
    this.flatBladePipes = shaders.blades_flat ? await ribbons(shaders.blades_flat, "colour by, ") : this.bladePipes;
    const scene = shaders.scene;
    const module = await this.compile(scene, "browser scene.wgsl");
    const layout = this.layoutFor(scene, GPUShaderStage.VERTEX | GPUShaderStage.FRAGMENT);
    const pl = device.createPipelineLayout({ bindGroupLayouts: [layout] });
    const blend = {
      color: { srcFactor: "src-alpha", dstFactor: "one-minus-src-alpha", operation: "add" },
      alpha: { srcFactor: "one", dstFactor: "one-minus-src-alpha", operation: "add" },
    };
    const make = (vs, fs, topology, depth, withBlend) => device.createRenderPipeline({
      layout: pl,
      vertex: { module, entryPoint: vs },
      fragment: { module, entryPoint: fs, targets: [{ format: this.format, blend: withBlend ? blend : undefined }] },
      primitive: { topology, cullMode: "none" },
      depthStencil: depth,
    });
    this.scenePipes = {
      layout,
      shader: scene,
      sky: make("vs_sky", "fs_sky", "triangle-list", { format: "depth24plus", depthWriteEnabled: false, depthCompare: "always" }, false),
      ground: make("vs_ground", "fs_ground", "triangle-strip", depthStencil, false),
      balls: make("vs_ball", "fs_ball", "triangle-list", { format: "depth24plus", depthWriteEnabled: false, depthCompare: "less" }, true),
    };
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
    const n = this.model.get("n_blades");
    const classes = this.lodSegments.length;
    this.n = n;
    this.res = {
      s_blades: buffer(n * 64, U.STORAGE | U.COPY_SRC | U.COPY_DST, "blades"),
      s_collision: buffer(n * 4, U.STORAGE | U.COPY_SRC | U.COPY_DST, "collision"),
      s_args: buffer(classes * 16, U.STORAGE | U.INDIRECT | U.COPY_SRC | U.COPY_DST, "draw args"),
      s_visible: buffer(classes * n * 4, U.STORAGE, "visible"),
      s_culled: buffer(n * 4, U.STORAGE, "culled"),
      s_culled_args: buffer(16, U.STORAGE | U.INDIRECT | U.COPY_DST, "culled draw args"),
      s_bands: buffer(2 * classes * Math.max(this.model.get("shaders").bands || 1, 1) * 4, U.STORAGE, "distance bands"),
      u_sim: buffer(this.model.get("sim_uniform").byteLength, U.UNIFORM | U.COPY_DST, "u_sim"),
      u_cull: buffer(this.model.get("cull_uniform").byteLength, U.UNIFORM | U.COPY_DST, "u_cull"),
      u_material: buffer(this.model.get("material_uniform").byteLength, U.UNIFORM | U.COPY_DST, "u_material"),
      u_stdinfo: buffer(this.model.get("stdinfo_size"), U.UNIFORM | U.COPY_DST, "u_stdinfo"),
      u_wobject: buffer(64, U.UNIFORM | U.COPY_DST, "u_wobject"),
      u_scene: buffer(96, U.UNIFORM | U.COPY_DST, "u_scene"),
      s_colliders: buffer(this.model.get("collider_buffer_bytes")[0], U.STORAGE | U.COPY_DST, "colliders"),
      s_collider_grid: buffer(this.model.get("collider_buffer_bytes")[1], U.STORAGE | U.COPY_DST, "collider grid"),
    };
    this.res.s_balls = this.res.s_colliders;  // the balls are drawn from the colliders' buffer
    this.argsRead = buffer(classes * 16, U.MAP_READ | U.COPY_DST, "args readback");
    device.queue.writeBuffer(this.res.u_wobject, 0, new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]));
    this.uploadRestPose();
    this.writeUniform("u_cull", "cull_uniform");
    this.writeUniform("u_material", "material_uniform");
    this.writeSceneUniform();
    this.writeBalls();
    this.makeBindGroups();
  }

  makeBindGroups() {
    const group = (p) => this.device.createBindGroup({
      layout: p.layout,
      entries: p.shader.bindings.map((b) => {
        const buffer = this.res[b.name];
        if (!buffer) throw new Error(`the browser engine has no resource named ${b.name}`);
        return { binding: b.binding, resource: { buffer } };
      }),
    });
    this.sim.group = group(this.sim);
    this.resetArgs.group = group(this.resetArgs);
    this.cull.group = group(this.cull);
    if (this.cullCount) { this.cullCount.group = group(this.cullCount); this.prefixBands.group = group(this.prefixBands); }
    for (const p of this.bladePipes) p.group = group(p);
    for (const p of this.flatBladePipes) p.group = group(p);
    this.scenePipes.group = group(this.scenePipes);
  }

  uploadRestPose() {
    const data = this.model.get("blade_data");
    const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
    this.device.queue.writeBuffer(this.res.s_blades, 0, bytes);
    this.device.queue.writeBuffer(this.res.s_collision, 0, new Float32Array(this.n));
    this.stepCount = 0;
    this.accumulator = 0;
  }

  // The ribbon pipelines for the current params.color_by (u_cull.color_by: 0 natural).
  ribbonPipes() {
    const off = this.model.get("shaders").color_by_offset;
    const cu = this.model.get("cull_uniform");
    const colorBy = off === undefined ? 1 : new DataView(cu.buffer, cu.byteOffset, cu.byteLength).getInt32(off, true);
    return colorBy === 0 ? this.bladePipes : this.flatBladePipes;
  }

  writeUniform(name, trait) {
    const data = this.model.get(trait);
    this.device.queue.writeBuffer(this.res[name], 0, new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  }

  writeSceneUniform() {
    const s = this.model.get("scene_style");
    const f = new Float32Array(24);
    f.set(s.sky_bottom, 0); f.set(s.sky_top, 4); f.set(s.ground_color, 8);
    f.set([...s.ground_center, s.ground_half], 12); f.set(s.ball_color, 16); f.set([...s.light_direction, 0], 20);
    this.device.queue.writeBuffer(this.res.u_scene, 0, f);
  }

  // The spheres and their grid, as Python built them (grasswidget.core.collider_grid).
  writeBalls() {
    for (const [name, trait] of [["s_colliders", "collider_spheres"], ["s_collider_grid", "collider_grid"]]) {
      const data = this.model.get(trait);
      if (data && data.byteLength) {
        this.device.queue.writeBuffer(this.res[name], 0, new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
      }
    }
    const spheres = this.model.get("collider_spheres");
    this.nBalls = spheres ? Math.floor(spheres.byteLength / 16) : 0;
  }

  // ---------------------------------------------------------------- simulation

  workgroups(items) {
    const groups = Math.max(1, Math.ceil(items / WORKGROUP));
    const x = Math.min(groups, 65535);
    return [x, Math.ceil(groups / x)];
  }

  // Exactly n fixed steps of dt, like GrassField.step (wind time (k dt) mod period).
  simulate(n) {
    if (n <= 0) return;
    const device = this.device;
    const clock = this.model.get("clock");
    const layout = this.model.get("sim_layout");
    const base = this.model.get("sim_uniform");
    const bytes = new Uint8Array(base.byteLength);
    bytes.set(new Uint8Array(base.buffer, base.byteOffset, base.byteLength));
    const view = new DataView(bytes.buffer);
    const perDispatch = Math.max(1, Math.floor(BLADE_STEPS_PER_DISPATCH / Math.max(this.n, 1)));
    const [gx, gy] = this.workgroups(this.n);
    let done = 0;
    while (done < n) {
      const chunk = Math.min(perDispatch, n - done);
      let t0 = this.stepCount * clock.dt;
      if (clock.wind_period > 0) t0 = t0 % clock.wind_period;
      view.setFloat32(layout.time0[0], t0, true);
      view.setInt32(layout.steps[0], chunk, true);
      device.queue.writeBuffer(this.res.u_sim, 0, bytes);
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

  writeStdInfo(width, height, target) {
    const { world, view, proj } = this.matrices(width / height);
    const f = new Float32Array(this.model.get("stdinfo_size") / 4);
    f.set(view, 0); f.set(world, 16); f.set(proj, 32); f.set(invert4(proj), 48);
    f.set([width, height, width, height], 64);
    this.device.queue.writeBuffer(target, 0, f);
  }

  // Encode cull + draw of the current state into a colour view of (width, height).
  encodeFrame(encoder, colorView, depthView, width, height) {
    this.writeStdInfo(width, height, this.res.u_stdinfo);
    const cpass = encoder.beginComputePass();
    cpass.setPipeline(this.resetArgs.pipeline);
    cpass.setBindGroup(0, this.resetArgs.group);
    cpass.dispatchWorkgroups(1);
    const [gx, gy] = this.workgroups(this.n);
    if (this.cullCount) {
      cpass.setPipeline(this.cullCount.pipeline);
      cpass.setBindGroup(0, this.cullCount.group);
      cpass.dispatchWorkgroups(gx, gy);
      cpass.setPipeline(this.prefixBands.pipeline);
      cpass.setBindGroup(0, this.prefixBands.group);
      cpass.dispatchWorkgroups(1);
    }
    cpass.setPipeline(this.cull.pipeline);
    cpass.setBindGroup(0, this.cull.group);
    cpass.dispatchWorkgroups(gx, gy);
    cpass.end();
    const pass = encoder.beginRenderPass({
      colorAttachments: [{ view: colorView, loadOp: "clear", storeOp: "store", clearValue: { r: 0.8, g: 0.87, b: 0.93, a: 1 } }],
      depthStencilAttachment: { view: depthView, depthLoadOp: "clear", depthClearValue: 1, depthStoreOp: "discard" },
    });
    const sp = this.scenePipes;
    pass.setBindGroup(0, sp.group);
    pass.setPipeline(sp.sky);
    pass.draw(3);
    pass.setPipeline(sp.ground);
    pass.draw(4);
    this.ribbonPipes().forEach((p, k) => {
      pass.setPipeline(p.pipeline);
      pass.setBindGroup(0, p.group);
      if (p.shader.culled) pass.drawIndirect(this.res.s_culled_args, 0);  // color_by "cull": the culled blades
      else pass.drawIndirect(this.res.s_args, 16 * k);
    });
    const balls = this.nBalls || 0;
    if (balls > 0 && this.model.get("show_colliders")) {
      pass.setPipeline(sp.balls);
      pass.setBindGroup(0, sp.group);
      pass.draw(6 * 16 * 32, balls);
    }
    pass.end();
  }

  depthFor(width, height) {
    return this.device.createTexture({ size: [width, height], format: "depth24plus", usage: GPUTextureUsage.RENDER_ATTACHMENT });
  }

  scheduleFrame() {
    if (this.closed || this.raf) return;
    this.raf = requestAnimationFrame((t) => { this.raf = null; this.frame(t); });
  }

  frame(now) {
    if (!this.ready || this.closed) return;
    this.scheduleFrame();
    const elapsed = this.lastTime === null ? 0 : (now - this.lastTime) / 1000;
    this.lastTime = now;
    if (this.inFlight >= MAX_FRAMES_IN_FLIGHT) return;
    const t0 = performance.now();
    try {
      if (this.model.get("playing")) {
        const dt = this.model.get("clock").dt;
        this.accumulator += Math.min(elapsed, MAX_FRAME_TIME) * this.model.get("time_scale");
        let n = Math.floor(this.accumulator / dt + 1e-9);
        if (n > MAX_STEPS_PER_FRAME) { n = MAX_STEPS_PER_FRAME; this.accumulator = 0; }
        else this.accumulator -= n * dt;
        if (n > 0) { this.onSteps(n); this.simulate(n); }
      } else {
        this.accumulator = 0;
      }
      const device = this.device;
      const w = this.canvas.width, h = this.canvas.height;
      if (!this.depth || this.depth.width !== w || this.depth.height !== h) {
        if (this.depth) this.depth.destroy();
        this.depth = this.depthFor(w, h);
      }
      const encoder = device.createCommandEncoder();
      this.encodeFrame(encoder, this.context.getCurrentTexture().createView(), this.depth.createView(), w, h);
      const readArgs = !this.argsReadPending && performance.now() - (this.lastArgsRead || 0) > STATS_INTERVAL_MS / 2;
      if (readArgs) encoder.copyBufferToBuffer(this.res.s_args, 0, this.argsRead, 0, this.argsRead.size);
      device.queue.submit([encoder.finish()]);
      this.inFlight += 1;
      device.queue.onSubmittedWorkDone().then(() => {
        this.inFlight -= 1;
        this.frames += 1;
        if (!this.timing.first_frame) this.timing.first_frame = performance.now();
        this.lastFrameMs = performance.now() - t0;
      }, () => { this.inFlight = 0; });
      if (readArgs) this.readArgs();
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
      this.visible = this.lodSegments.map((_, k) => a[4 * k + 1]);
      this.visibleAt = performance.now();
      this.argsReadPending = false;
    }, () => { this.argsReadPending = false; });
  }

  maybeSendStats() {
    const now = performance.now();
    if (now - this.statsTime < STATS_INTERVAL_MS) return;
    const fps = ((this.frames - this.statsFrames) * 1000) / (now - this.statsTime);
    this.statsFrames = this.frames;
    this.statsTime = now;
    const steps = this.pendingSteps || 0;
    this.pendingSteps = 0;
    this.report("stats", "", {
      fps, visible: this.visible, step_count: this.stepCount, steps, frame_ms: this.lastFrameMs,
      frame_size: [this.canvas.width, this.canvas.height], adapter: this.adapterText,
    });
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

  async snapshot(msg) {
    const device = this.device;
    const w = msg.width, h = msg.height;
    const color = device.createTexture({ size: [w, h], format: this.format,
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
    const depth = this.depthFor(w, h);
    const row = Math.ceil((w * 4) / 256) * 256;
    const out = device.createBuffer({ size: row * h, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
    const encoder = device.createCommandEncoder();
    this.encodeFrame(encoder, color.createView(), depth.createView(), w, h);
    encoder.copyTextureToBuffer({ texture: color }, { buffer: out, bytesPerRow: row }, [w, h]);
    device.queue.submit([encoder.finish()]);
    await out.mapAsync(GPUMapMode.READ);
    const src = new Uint8Array(out.getMappedRange());
    const rgba = new Uint8Array(w * h * 4);
    const bgra = this.format.startsWith("bgra");
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
    out.unmap(); out.destroy(); color.destroy(); depth.destroy();
    this.model.send({ type: "snapshot", id: msg.id, width: w, height: h }, undefined, [rgba.buffer]);
  }

  async compileSimulate(msg) {
    try {
      const sim = await this.computePipeline(msg.shader, "simulate.wgsl");
      this.sim = sim;
      this.makeBindGroups();
      this.report("compiled", "", { id: msg.id, ok: true });
    } catch (err) {
      // The old simulation pipeline stays in force.
      this.report("compiled", err.message, { id: msg.id, ok: false, messages: err.messages || [] });
    }
  }

  // ---------------------------------------------------------------- trait changes

  onChange(name) {
    if (!this.ready) return;
    try {
      switch (name) {
        case "cull_uniform": this.writeUniform("u_cull", "cull_uniform"); break;
        case "material_uniform": this.writeUniform("u_material", "material_uniform"); break;
        case "collider_spheres": case "collider_grid": this.writeBalls(); break;
        case "scene_style": this.writeSceneUniform(); break;
        case "blade_data": this.buildBuffers(); break;
        case "width": case "height": case "pixel_ratio": this.resize(); break;
        default: break;
      }
    } catch (err) {
      this.report("error", `browser engine: applying ${name} failed: ${err.message || err}`);
    }
  }

  close() {
    this.closed = true;
    if (this.raf) cancelAnimationFrame(this.raf);
    for (const off of this.handlers) off();
    if (this.device) { const d = this.device; this.device = null; d.destroy(); }
    this.wrapper.remove();
  }
}

const ENGINES = (globalThis.__grasswidgetEngines = globalThis.__grasswidgetEngines || new Set());

export default {
  render({ model, el }) {
    const engine = new GrassEngine(model, el);
    ENGINES.add(engine);
    const onMsg = (msg, buffers) => { engine.onMessage(msg, buffers); };
    model.on("msg:custom", onMsg);
    const names = ["cull_uniform", "material_uniform", "collider_spheres", "collider_grid", "scene_style", "blade_data", "width", "height",
      "pixel_ratio"];
    const listeners = names.map((name) => {
      const fn = () => engine.onChange(name);
      model.on(`change:${name}`, fn);
      return [name, fn];
    });
    engine.start();
    return () => {
      model.off("msg:custom", onMsg);
      for (const [name, fn] of listeners) model.off(`change:${name}`, fn);
      ENGINES.delete(engine);
      engine.close();
    };
  },
};
