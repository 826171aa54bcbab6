// @ts-check
// grasswidget's browser engine: the project's WGSL simulation, culling and ribbons, run in the
// notebook's browser with WebGPU (an anywidget ES module; shipped inside the wheel, nothing is
// fetched at run time). This file is the entry: anywidget's initialize() and render().
//
// The engine only executes what Python describes (grasswidget/browser/engine_widget.py):
//   traits   engine_key (one engine per widget model), blade_data (rest pose, N x 64 bytes),
//            n_blades, shaders (WGSL text + binding maps + the compute passes of a frame, in
//            order), sim_uniform / cull_uniform / material_uniform / sky_ground_uniform /
//            ball_uniform (packed structs, computed in Python: grasswidget.core.engine_inputs),
//            sim_layout / stdinfo_layout (field offsets), frame_rules (every rule of a frame as
//            data, grasswidget.core.engine_inputs.frame_rules: {clock, dispatch, orbit, drag, style}),
//            playing, time_scale, camera ({position, target, fov_deg, near, far}),
//            collider_spheres / collider_grid (the colliders and their grid, bytes;
//            grasswidget.core.collider_grid; the balls are drawn from the spheres),
//            show_colliders, report_steps, stats_interval_ms (how often the stats message goes),
//            width, height, pixel_ratio, frustum_lines (the frozen culling camera's 12 edges,
//            24 x 3 float32; empty: not frozen), inspect_uniform (u_inspect packed) and
//            inspected (the inspected blade ids).
//   messages GrassEngine.messages (requests from Python, kind -> handler; js/messages.js reads the GPU
//            back for the answers) and js/stats.js (the stats and steps reports).
//
// The modules, by role (each a real ES module; grasswidget.browser.esm.engine_module_text
// assembles them into the one module text anywidget, the live page and the HTML export load):
//   js/linalg.js       vector and 4 x 4 matrix math
//   js/rules.js        what the engine must still compute per frame, each rule the twin of one
//                      Python function that decides it, with every number from Python's frame_rules
//   js/pictures.js     exported pictures filtered down (Python's export_filter)
//   js/canvas_view.js  CanvasView: one display of the widget, a canvas and its input
//   js/device.js       EngineDevice: WebGPU start-up, shader compilation, the pipeline cache
//   js/pipelines.js    EnginePipelines: the pipelines of one set of Python's shaders
//   js/culling.js      Occlusion, ComputeRaster: occlusion culling's two phases, the compute rasterizer
//   js/resources.js    EngineResources: buffers, Python's bytes into them (every uniform one route), bind groups
//   js/passes.js       Simulation (the fixed steps), FramePasses (one frame of a view encoded)
//   js/camera.js       CameraRig: the camera held to Python's orbit limits, its matrices
//   js/stats.js        EngineStats: frame counts and times, the stats and steps reports
//   js/messages.js     the answers that read the GPU back (state, inspected blades, pictures)
//   types.js           the types (Model, FrameRules...) for tsc --checkJs; no code, not in the module text
// GrassEngine (below) owns the state (step count, clock, views, start-up and device loss) and the
// frame loop, and holds one of each; each is built with what it needs and reaches into no other.
// Every number of the engine is Python's: frame_rules.engine (core.engine_inputs.engine_rules).
//
// A compute pass or an overlay with "only_if" runs while its condition holds ("frozen",
// "inspecting", "compute_raster"); a pass with sim_uniform "now" gets u_sim for the time of the next
// step (no steps) first, as the kernel's inspector does. Fixed steps: step(n) runs exactly n steps
// of dt; playing follows the wall clock with the rules of grasswidget.views.clock.SimClock.
// Views at rest: a view that is not visible (scrolled away, a collapsed output, a hidden tab: an
// IntersectionObserver per canvas and document.visibilityState) draws nothing; with no view visible
// the engine simulates nothing, sends no stats and asks for no animation frame, and its clock stops
// as pause() stops it (SimClock.stop, Python's rule): on return simulated time goes on from where it
// stopped. canvas.grasswidgetFramesDrawn counts a view's frames (tests).
//
// One engine per widget model (GPU device, buffers, simulation, clock), however many times the
// widget is displayed: anywidget's initialize() makes it, each render() only adds a view (a
// canvas) of it, and every visible view draws the same meadow from the same camera.

import { CanvasView } from "./js/canvas_view.js";
import { CameraRig } from "./js/camera.js";
import { EngineDevice } from "./js/device.js";
import { readInspected, readState, snapshot } from "./js/messages.js";
import { FramePasses, Simulation } from "./js/passes.js";
import { EnginePipelines } from "./js/pipelines.js";
import { EngineResources } from "./js/resources.js";
import { SimClock } from "./js/rules.js";
import { EngineStats } from "./js/stats.js";

export { SimClock, clampOrbit, hzbLayout } from "./js/rules.js";
export { downsample } from "./js/pictures.js";

/** @typedef {import("./types.js").Model} Model */
/** @typedef {import("./types.js").Camera} Camera */
/** @typedef {(msg: any, buffers?: any) => (void | Promise<void>)} Handler */

/**
 * The engine of one widget model: the state and the frame loop; the device, pipelines, resources,
 * passes, camera and stats are objects it holds (js/*.js), made again when the device or the
 * shaders change.
 */
class GrassEngine {
  /** @param {Model} model the model handle of anywidget's initialize(): lives as long as the model */
  constructor(model) {
    this.model = model;
    /** @type {Set<CanvasView>} */
    this.views = new Set();
    /** @type {[any, any][]} messages that arrived before the device was ready or while rebuilding */
    this.queue = [];
    this.ready = false;
    this.starting = false;
    this.rebuilding = false;
    this.rebuildAgain = false;
    this.shadersChangedWhileStarting = false;
    this.closed = false;
    this.resting = false;
    this.stepCount = 0;
    // The clock's step cap is read from frame_rules every frame (Python sends it after the model opens).
    this.clock = new SimClock(1);
    this.inFlight = 0;        // frames submitted whose GPU work is not done
    this.expectLoss = false;  // lose_device (tests) asked for the loss
    this.recoveries = 0;      // restarts after a lost device
    this.noteText = "starting WebGPU…";
    /** @type {number | null} */
    this.raf = null;
    // Start-up milestones (performance.now() ms), read by benchmarks.
    /** @type {Record<string, number>} */
    this.timing = { created: performance.now() };
    this.rig = new CameraRig(model);
    this.stats = new EngineStats((kind, message, extra) => this.report(kind, message, extra));
    /** @type {EngineDevice | null} */
    this.gpu = null;
    /** @type {EnginePipelines | null} */
    this.pipelines = null;
    /** @type {EngineResources | null} */
    this.resources = null;
    /** @type {Simulation | null} */
    this.simulation = null;
    /** @type {FramePasses | null} */
    this.passes = null;
    /** Python's requests (the comm's custom messages), by kind. @type {Record<string, Handler>} */
    this.messages = {
      step: (msg) => this.simulate(msg.n),
      reset: () => this.restPose(),
      clear_reset_flag: () => this.resources.clearResetFlag(),
      read_state: (msg) => readState(this.gpu, this.resources, model, msg.id, this.stepCount),
      read_inspected: (msg) => readInspected(this.gpu, this.pipelines, this.resources, model, msg.id, this.stepCount,
        () => this.simulation.writeNow(this.stepCount)),
      sync: (msg) => this.report("synced", "", { id: msg.id }),
      snapshot: (msg) => snapshot(this.gpu, this.passes, model, msg),
      compile_simulate: (msg) => this.compileSimulate(msg),
      lose_device: () => { this.expectLoss = true; this.gpu.device.destroy(); },
    };
    /** Trait changes applied while ready, by trait (the uniforms: frame_rules.engine.uniforms). @type {Record<string, () => void>} */
    this.changes = {
      collider_spheres: () => this.resources.writeBalls(),
      collider_grid: () => this.resources.writeBalls(),
      frustum_lines: () => this.resources.writeFrustum(),
      blade_data: () => { this.resources.build(this.pipelines); this.restPose(); },
      shaders: () => { this.rebuildPipelines(); },
    };
    this.listen();
    this.onPageVisibility = () => this.visibilityChanged();
    document.addEventListener("visibilitychange", this.onPageVisibility);
  }

  /** @returns {import("./types.js").FrameRules} Python's frame_rules (grasswidget.core.engine_inputs.frame_rules) */
  rules() { return this.model.get("frame_rules"); }

  listen() {
    this.onMsg = (/** @type {any} */ msg, /** @type {any} */ buffers) => { this.onMessage(msg, buffers); };
    this.model.on("msg:custom", this.onMsg);
    /** @type {[string, () => void][]} */
    this.listeners = [];
    for (const name of ["collider_spheres", "collider_grid", "frame_rules", "blade_data", "width", "height",
      "pixel_ratio", "frustum_lines", "shaders"]) this.listenTo(name);
    this.listenToUniforms();
  }

  /** @param {string} name a trait whose changes onChange applies */
  listenTo(name) {
    if (this.listeners.some(([n]) => n === name)) return;
    const fn = () => this.onChange(name);
    this.model.on(`change:${name}`, fn);
    this.listeners.push([name, fn]);
  }

  /** The uniforms' traits (frame_rules.engine.uniforms: Python sends frame_rules after the model opens). */
  listenToUniforms() {
    const rules = this.rules();
    if (rules && rules.engine) for (const [, trait] of rules.engine.uniforms) this.listenTo(trait);
  }

  // ---------------------------------------------------------------- what CanvasView and tests read

  /** Frames whose GPU work completed. */
  get frames() { return this.stats.frames; }
  /** Blades of the field (0 before the device starts). */
  get n() { return this.resources ? this.resources.n : 0; }
  /** Blades drawn per LOD class by the last counted frame. */
  get visible() { return this.stats.visible; }
  get visibleAt() { return this.stats.visibleAt; }
  get occluded() { return this.stats.occluded; }
  get rastered() { return this.stats.rastered; }
  get countsSwitches() { return this.stats.countsSwitches; }
  /** When (performance.now() ms) the newest read-back of the counters was issued; 0 before any. */
  get countsReadAt() { return this.stats.lastArgsRead; }
  /** Whether that read-back is still in flight (its counts not in `visible` yet). */
  get countsPending() { return this.stats.argsReadPending; }
  /** @returns {string | undefined} the adapter in words */
  get adapterText() { return this.gpu ? this.gpu.adapterText : undefined; }
  /** @returns {GPUDevice | null} */
  get device() { return this.gpu ? this.gpu.device : null; }

  /** @returns {Camera} the camera now (CanvasView's drags start from it) */
  camera() { return this.rig.get(); }
  /** @param {Camera} cam @param {boolean} sync */
  setCamera(cam, sync) { this.rig.set(cam, sync); }
  /** @param {number} aspect */
  matrices(aspect) { return this.rig.matrices(aspect); }
  /** @param {number} width @param {number} height @returns {GPUTexture} */
  depthFor(width, height) { return this.passes.depthFor(width, height); }

  // ---------------------------------------------------------------- views

  /** @param {CanvasView} view */
  addView(view) {
    this.views.add(view);
    if (this.ready) view.configure(this.gpu.device, this.gpu.format);
    if (!this.gpu && !this.starting) this.start();  // the GPU starts with the first view
    this.scheduleFrame();
  }

  /** @param {CanvasView} view */
  removeView(view) {
    this.views.delete(view);
    view.close();
  }

  /** The views that can be seen now; none: the engine rests (no simulation, no drawing, no stats). */
  visibleViews() { return [...this.views].filter((v) => v.visible()); }

  // A view was scrolled in or out of sight, or the tab was shown or hidden. Resting stops the
  // clock as pause() does (Python's SimClock.stop: no time is owed for the time out of sight),
  // so on return simulated time goes on from where it stopped, without a catch-up burst.
  visibilityChanged() {
    if (this.closed) return;
    if (this.visibleViews().length) this.scheduleFrame();
    else this.rest();
  }

  /** Tells Python once per stretch at rest ("rest"): its stats then say they are of the last frame. */
  rest() {
    this.clock.stop();
    if (!this.resting) this.report("rest", "", { step_count: this.stepCount });
    this.resting = true;
  }

  /** @param {string} text */
  setNote(text) {
    this.noteText = text;
    for (const v of this.views) v.note.textContent = text;
  }

  // ---------------------------------------------------------------- start-up and device loss

  /** @param {string} state @param {string} [detail] */
  status(state, detail) {
    this.model.set("gpu_status", { state, detail: detail || "" });
    this.model.save_changes();
  }

  async start() {
    this.starting = true;
    try {
      const opened = await EngineDevice.open(this.model.get("shaders").max_storage_buffers || 8);
      if (typeof opened === "string") {
        this.setNote("WebGPU is not available in this browser");
        this.status("unavailable", opened);
        return;
      }
      if (this.closed) { opened.device.destroy(); return; }
      const gpu = opened;
      this.gpu = gpu;
      gpu.device.lost.then((lost) => this.onDeviceLost(gpu, lost));
      gpu.device.onuncapturederror = (ev) => this.report("error", `WebGPU error: ${ev.error.message}`);
      for (const v of this.views) v.configure(gpu.device, gpu.format);
      this.timing.device = performance.now();
      await this.buildPipelines();
      this.timing.pipelines = performance.now();
      this.resources = new EngineResources(gpu, this.model);
      this.resources.build(this.pipelines);
      this.makePasses();
      this.restPose();
      this.timing.buffers = performance.now();
      this.setNote("");
      this.ready = true;
      this.status("ok", gpu.adapterText);
      if (this.shadersChangedWhileStarting) {  // built from the shaders before that change
        this.shadersChangedWhileStarting = false;
        this.rebuildPipelines();
      }
      await this.drainQueue();
      this.scheduleFrame();
    } catch (err) {
      this.setNote(`WebGPU start failed: ${err.message || err}`);
      this.status("unavailable", `start failed: ${err.message || err}`);
    } finally {
      this.starting = false;
    }
  }

  /** The pipelines of the shaders Python sent last. */
  async buildPipelines() {
    this.pipelines = await EnginePipelines.build(this.gpu, this.model.get("shaders"));
  }

  /** The simulation and the frame's passes for the pipelines and resources now held. */
  makePasses() {
    const { gpu, pipelines, resources, model } = this;
    this.simulation = new Simulation(gpu, pipelines, resources, model);
    this.passes = new FramePasses({ gpu, pipelines, resources, model, rig: this.rig, active: (c) => this.active(c),
      writeSimNow: () => this.simulation.writeNow(this.stepCount) });
  }

  /**
   * @param {string} kind @param {string} message @param {object} [extra]
   */
  report(kind, message, extra) {
    try { this.model.send({ type: kind, message, ...(extra || {}) }); } catch (e) { /* comm closed */ }
  }

  /** @param {EngineDevice} gpu @param {GPUDeviceLostInfo} lost */
  onDeviceLost(gpu, lost) {
    if (gpu !== this.gpu || this.closed) return;
    if (lost.reason === "destroyed" && !this.expectLoss) return;
    this.expectLoss = false;
    this.ready = false;
    this.gpu = null;
    if (this.resources) this.resources.destroy();
    this.resources = null;
    const why = lost.message || lost.reason || "unknown";
    if (this.recoveries < this.rules().engine.device_loss_retries) {
      this.recoveries += 1;
      this.report("device_lost", `the browser lost its WebGPU device (${why}); restarting the browser engine from the rest pose`);
      this.stepCount = 0;
      this.start();
    } else {
      this.report("device_lost", `the browser lost its WebGPU device (${why}) again; giving up`);
      this.status("unavailable", `device lost: ${why}`);
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
        const old = this.pipelines;
        if (old && old.occlusion) old.occlusion.dropTargets();
        if (old && old.raster) old.raster.dropTargets();
        await this.buildPipelines();
        this.resources.bind(this.pipelines);
        this.makePasses();
      } while (this.rebuildAgain && !this.closed);
    } catch (err) {
      this.report("error", `browser engine: building the pipelines of the new shaders failed: ${err.message || err}`);
    } finally {
      this.rebuilding = false;
      await this.drainQueue();
      this.scheduleFrame();
    }
  }

  async drainQueue() {
    const pending = this.queue;
    this.queue = [];
    for (const [msg, buffers] of pending) await this.onMessage(msg, buffers);
  }

  /**
   * Whether a pass or overlay with this "only_if" runs now (no condition: always).
   * @param {string | undefined} condition
   */
  active(condition) {
    if (!condition) return true;
    if (condition === "frozen") return this.model.get("frustum_lines").byteLength > 0;
    if (condition === "inspecting") return (this.model.get("inspected") || []).length > 0;
    if (condition === "compute_raster") return this.passes.rasterOn();
    return false;
  }

  // ---------------------------------------------------------------- the state

  /** The rest pose written, step 0, the clock from now. */
  restPose() {
    this.resources.writeRestPose();
    this.stepCount = 0;
    this.clock.reset(performance.now() / 1000);
  }

  /** Exactly n fixed steps of dt, like GrassField.step. @param {number} n */
  simulate(n) {
    if (n <= 0) return;
    this.simulation.run(n, this.stepCount);
    this.stepCount += n;
  }

  /** A compiled wind swapped in; the old pipelines stay in force when it does not compile. @param {any} msg */
  async compileSimulate(msg) {
    try {
      await this.pipelines.swapSimulate(this.gpu, msg.shader, msg.passes);
      this.resources.bind(this.pipelines);
      this.report("compiled", "", { id: msg.id, ok: true });
    } catch (err) {
      this.report("compiled", err.message, { id: msg.id, ok: false, messages: err.messages || [] });
    }
  }

  // ---------------------------------------------------------------- messages and trait changes

  /** @param {any} msg @param {any} buffers */
  async onMessage(msg, buffers) {
    if (!this.ready || this.rebuilding) {
      this.queue.push([msg, buffers]);
      return;
    }
    const handler = Object.prototype.hasOwnProperty.call(this.messages, msg.type) ? this.messages[msg.type] : null;
    if (!handler) return;
    try {
      await handler(msg, buffers);
    } catch (err) {
      this.report("error", `browser engine: ${msg.type} failed: ${err.message || err}`, { id: msg.id });
    }
  }

  /** @param {string} name */
  onChange(name) {
    if (name === "frame_rules") this.listenToUniforms();
    if (name === "width" || name === "height" || name === "pixel_ratio") {
      for (const v of this.views) v.resize();
      return;
    }
    if (name === "shaders" && this.starting) this.shadersChangedWhileStarting = true;
    if (!this.ready) return;
    try {
      const uniform = this.resources.uniformOf(name);
      if (uniform) this.resources.writeUniform(uniform);
      else if (Object.prototype.hasOwnProperty.call(this.changes, name)) this.changes[name]();
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
    const gpu = this.gpu;
    this.gpu = null;
    if (gpu) gpu.device.destroy();
  }

  // ---------------------------------------------------------------- the frame loop

  scheduleFrame() {
    if (this.closed || this.raf || !this.visibleViews().length) return;
    this.raf = requestAnimationFrame((t) => { this.raf = null; this.frame(t); });
  }

  // One animation frame: the clock's steps (once, whatever the number of views), then every visible
  // view drawn. With no view visible nothing runs and no new frame is asked for: the engine rests
  // until visibilityChanged() finds a view in sight again.
  /** @param {number} now ms */
  frame(now) {
    if (!this.ready || this.closed) return;
    if (this.rebuilding) return;  // rebuildPipelines asks for the next frame when done
    const shown = this.visibleViews();
    if (!shown.length) { this.rest(); return; }
    if (this.resting) {
      this.resting = false;
      this.stats.restart();
    }
    this.scheduleFrame();
    const rules = this.rules();
    if (this.inFlight >= rules.engine.frames_in_flight) return;
    const t0 = performance.now();
    try {
      this.clock.maxSteps = rules.clock.max_steps_per_frame;
      if (this.model.get("playing")) {
        this.clock.start(now / 1000);
        const n = this.clock.frameSteps(now / 1000, rules.clock.dt, this.model.get("time_scale"));
        if (n > 0) { this.stats.stepsRan(n, this.model.get("report_steps"), rules.input.steps_report_ms); this.simulate(n); }
      } else {
        this.clock.stop();
      }
      const device = this.gpu.device;
      const passes = this.passes;
      // The switch state this frame executes ([occlusion, compute raster], Python's u_cull words):
      // its time and counts are reported with it (grasswidget.browser.trial_feed measures by them).
      const switches = [passes.occlusionOn(), passes.rasterOn()];
      let first = true;
      for (const view of shown) {
        if (!view.context) continue;
        const { color, depth, w, h } = view.targets();
        const encoder = device.createCommandEncoder();
        passes.encode(encoder, color, depth, w, h);
        const readCounts = first && this.stats.wantsCounts(this.model.get("stats_interval_ms"));
        if (readCounts) passes.encodeCounters(encoder);
        device.queue.submit([encoder.finish()]);
        if (readCounts) {
          this.stats.readCounts(this.resources.argsRead, rules.counters, switches, !!this.pipelines.occlusion,
            !!this.pipelines.raster);
        }
        if (first) this.stats.drewSize(w, h);
        first = false;
        view.countFrame();
      }
      this.inFlight += 1;
      device.queue.onSubmittedWorkDone().then(() => {
        this.inFlight -= 1;
        if (!this.timing.first_frame) this.timing.first_frame = performance.now();
        this.stats.frameDone(switches, performance.now() - t0, this.rules().engine.frame_times_kept);
      }, () => { this.inFlight = 0; });
    } catch (err) {
      this.report("error", `browser frame failed: ${err.message || err}`);
    }
    this.stats.maybeSend(this.model.get("stats_interval_ms"),
      { step_count: this.stepCount, adapter: this.gpu ? this.gpu.adapterText : undefined, views: this.views.size });
  }
}

// engine_key -> GrassEngine, for the whole page (the module is loaded once per page).
const ENGINES = (globalThis.__grasswidgetEngines = globalThis.__grasswidgetEngines || new Map());

/** @param {Model} model @returns {GrassEngine} the model's one engine */
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
  /** @param {{model: Model}} args */
  initialize({ model }) {
    const engine = engineFor(model);
    return () => {
      engine.close();
      if (ENGINES.get(model.get("engine_key")) === engine) ENGINES.delete(model.get("engine_key"));
    };
  },
  // Once per display of the widget: one more view of the same engine.
  /** @param {{model: Model, el: HTMLElement}} args */
  render({ model, el }) {
    const engine = engineFor(model);
    const view = new CanvasView(engine, model, el);
    engine.addView(view);
    return () => engine.removeView(view);
  },
};
