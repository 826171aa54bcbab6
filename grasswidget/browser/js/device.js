// The browser engine's device and pipelines (see engine.js for the whole protocol).

import { SimClock, clampOrbit } from "./rules.js";

/**
 * The engine's device and pipelines: one engine per widget model (anywidget's initialize()),
 * however many canvases show it. Starts WebGPU with the first view, compiles Python's shaders
 * into the pipelines of a frame, holds the views and the camera (held to Python's orbit limits).
 * The rest of the engine extends it: resources.js, culling.js, passes.js, messages.js.
 */
export class EngineDevice {
  /** @param {object} model the model handle of anywidget's initialize() */
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

  /** @returns {{clock: object, orbit: object, drag: object, dispatch: object, stats: object, style: object}}
   * Python's frame_rules (grasswidget.core.engine_inputs.frame_rules) */
  rules() { return this.model.get("frame_rules"); }

  listen() {
    this.onMsg = (msg, buffers) => { this.onMessage(msg, buffers); };
    this.model.on("msg:custom", this.onMsg);
    const names = ["cull_uniform", "material_uniform", "sky_ground_uniform", "ball_uniform", "collider_spheres", "collider_grid",
      "frame_rules", "blade_data", "width", "height", "pixel_ratio", "frustum_lines", "inspect_uniform", "shaders"];
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

  // Tells Python once per stretch at rest ("rest"): its stats then say they are of the last frame.
  rest() {
    this.clock.stop();
    if (!this.resting) this.report("rest", "", { step_count: this.stepCount });
    this.resting = true;
  }

  setNote(text) {
    this.noteText = text;
    for (const v of this.views) v.note.textContent = text;
  }

  camera() { return this.model.get("camera"); }

  // Set the camera (held to the orbit limits from Python); sync to Python at most every
  // frame_rules.drag.sync_ms unless asked.
  setCamera(cam, sync) {
    const [position, target] = clampOrbit(cam.position, cam.target, this.rules().orbit);
    this.model.set("camera", { ...cam, position, target });
    const now = performance.now();
    if (sync || !this.lastCamSync || now - this.lastCamSync > this.rules().drag.sync_ms) {
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
      if (this.shadersChangedWhileStarting) {  // built from the shaders before that change
        this.shadersChangedWhileStarting = false;
        this.rebuildPipelines();
      }
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

  // The pipelines built for the shaders Python sent last and the time before, by their text and
  // state (key): a change of the shaders (the sunlight's switch, a new wind) builds only the
  // pipelines of the texts that changed, and switching back builds none.
  cachedPipeline(key) {
    if (this.pipelineCache && this.pipelineCache.device !== this.device) this.pipelineCache = null;
    const cache = this.pipelineCache;
    if (!cache) return null;
    const hit = cache.now.get(key) || cache.before.get(key);
    if (hit) cache.now.set(key, hit);
    return hit || null;
  }

  keepPipeline(key, pipe) {
    if (!this.pipelineCache) this.pipelineCache = { device: this.device, now: new Map(), before: new Map() };
    this.pipelineCache.now.set(key, pipe);
    return pipe;
  }

  async computePipeline(shader, label) {
    const key = `compute\n${shader.code}`;
    const hit = this.cachedPipeline(key);
    if (hit) return { ...hit, shader };
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
    return this.keepPipeline(key, { pipeline, layout, shader });
  }

  // The pipelines of a frame, from the shaders Python sent: the compute passes in the
  // order Python lists them (shaders.compute_passes: culling, LOD binning, draw order;
  // a new pass is one more entry there), the ribbon draws, sky and ground
  // (shaders/sky_ground.wgsl, as in the kernel engine) and the collider balls.
  async buildPipelines() {
    const device = this.device;
    const shaders = this.model.get("shaders");
    if (this.pipelineCache) {  // this build's pipelines are "now", the last build's "before"
      this.pipelineCache.before = this.pipelineCache.now;
      this.pipelineCache.now = new Map();
    }
    this.lodSegments = shaders.lod_segments;
    this.sim = await this.computePipeline(shaders.simulate, "simulate.wgsl");
    this.computePasses = [];
    for (const pass of shaders.compute_passes) {
      const pipe = await this.computePipeline(shaders[pass.shader], pass.label || pass.shader);
      this.computePasses.push({ ...pipe, dispatch: pass.dispatch, name: pass.shader, label: pass.label || pass.shader,
        onlyIf: pass.only_if, simNow: pass.sim_uniform === "now", sized: !!pass.sized,
        indirectOffset: pass.indirect_offset || 0 });
    }
    this.depthFormat = (shaders.occlusion && shaders.occlusion.depth_format) || "depth24plus";
    const depthStencil = { format: this.depthFormat, depthWriteEnabled: true, depthCompare: "less" };
    const renderPipeline = this.renderPipeline = async (shader, label, { topology, depth, blend }) => {
      const key = JSON.stringify(["render", shader.code, shader.vertex, shader.fragment, this.format, topology, depth, blend]);
      const hit = this.cachedPipeline(key);
      if (hit) return { ...hit, shader };
      const module = await this.compile(shader, label);
      const layout = this.layoutFor(shader, GPUShaderStage.VERTEX | GPUShaderStage.FRAGMENT);
      const pipeline = await device.createRenderPipelineAsync({
        layout: device.createPipelineLayout({ bindGroupLayouts: [layout] }),
        vertex: { module, entryPoint: shader.vertex || "vs_main" },
        fragment: { module, entryPoint: shader.fragment || "fs_main", targets: [{ format: this.format, blend }] },
        primitive: { topology, cullMode: "none" },
        depthStencil: depth,
      });
      return this.keepPipeline(key, { pipeline, layout, shader });
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

  // Python sent other shaders (the "shaders" trait: the sunlight's switch, GrassParams.shadows,
  // selects the draws' set; a compiled wind): the pipelines are built again from them (the
  // unchanged texts' from the cache) and bound again; frames and requests wait meanwhile.
  async rebuildPipelines() {
    if (this.rebuilding) { this.rebuildAgain = true; return; }
    this.rebuilding = true;
    try {
      do {
        this.rebuildAgain = false;
        if (this.occlusion) this.dropOcclusionTargets();
        if (this.raster) this.dropRasterTargets();
        await this.buildPipelines();
        this.makeBindGroups();
      } while (this.rebuildAgain && !this.closed);
    } catch (err) {
      this.report("error", `browser engine: building the pipelines of the new shaders failed: ${err.message || err}`);
    } finally {
      this.rebuilding = false;
      const pending = this.queue;
      this.queue = [];
      for (const [msg, buffers] of pending) await this.onMessage(msg, buffers);
      this.scheduleFrame();
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
}
