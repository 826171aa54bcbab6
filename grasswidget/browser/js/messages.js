// The browser engine's messages: requests from Python (the comm's custom messages) answered,
// trait changes applied, and what the engine tells Python on its own (stats, steps).
//
// Requests: step {n}, reset, read_state {id}, snapshot {id, width, height, filter}
//   (filter: grasswidget.core.engine_inputs.export_filter, the supersampling), read_inspected {id},
//   sync {id} (answered at once: "synced"), compile_simulate {id, shader, passes}, lose_device (tests).
// Answers and reports: state, snapshot, inspected, compiled, synced, stats, steps, pick, ball, key,
//   rest (no view on screen: nothing is drawn until one is), error and device_lost messages; the
//   gpu_status trait.
// Stats {fps, visible (per LOD class), occluded, rastered, step_count, steps, frame_ms, frame_size,
//   adapter, views, frame_times, timed_switches, counts_switches}: every stats_interval_ms (Python's
//   trait), decoded in Python by grasswidget.browser.engine_view. frame_times: the ms (start to
//   onSubmittedWorkDone) of the frames since the last message drawn with the switch state
//   timed_switches ([occlusion, compute raster] as executed from u_cull; the list restarts when it
//   changes); counts_switches: the state of the frame the counts are of. Python's "auto" switches
//   (grasswidget.browser.trial_feed) measure by them and answer with new u_cull words.

import { EnginePasses } from "./passes.js";
import { downsample } from "./pictures.js";
import { UNIFORM_TRAITS } from "./resources.js";

/** Python's requests, trait changes and the engine's own reports (the passes: EnginePasses). */
export class EngineMessages extends EnginePasses {
  // ---------------------------------------------------------------- requests from Python

  async onMessage(msg, buffers) {
    if (!this.ready || this.rebuilding) {
      this.queue.push([msg, buffers]);
      return;
    }
    try {
      switch (msg.type) {
        case "step": this.simulate(msg.n); break;
        case "reset": this.uploadRestPose(); break;
        // the finite check's flag (after the collision strengths) back to 0, once Python has read it
        case "clear_reset_flag": this.device.queue.writeBuffer(this.res.s_collision, this.n * 4, new Float32Array(1)); break;
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
    const collision = b.getMappedRange().slice(0, (this.n + 1) * 4);  // the strengths and the reset flag
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
    const steps = this.stepCount;  // the state read: a step asked for meanwhile runs after it
    await Promise.all([a.mapAsync(GPUMapMode.READ), b.mapAsync(GPUMapMode.READ)]);
    const forces = a.getMappedRange().slice(0, forcesBytes);
    const points = b.getMappedRange().slice(0, pointsBytes);
    a.destroy(); b.destroy();
    this.model.send({ type: "inspected", id, n, step_count: steps }, undefined, [forces, points]);
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
    if (name === "shaders" && this.starting) this.shadersChangedWhileStarting = true;
    if (!this.ready) return;
    try {
      const uniform = UNIFORM_TRAITS.find(([, trait]) => trait === name);
      if (uniform) this.writeUniform(uniform[0], uniform[1]);
      else if (name === "collider_spheres" || name === "collider_grid") this.writeBalls();
      else if (name === "frustum_lines") this.writeFrustum();
      else if (name === "blade_data") this.buildBuffers();
      else if (name === "shaders") this.rebuildPipelines();
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

  // ---------------------------------------------------------------- reports to Python

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

  // Milliseconds between stats messages: Python's stats_interval_ms (default
  // grasswidget.core.engine_inputs.STATS_INTERVAL_MS; the lab bench asks for 200 while a chart is shown).
  statsInterval() {
    return this.model.get("stats_interval_ms");
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
      frame_times: this.frameTimes || [], timed_switches: this.timedSwitches || null,
      counts_switches: this.countsSwitches || null,
    });
    this.frameTimes = [];
  }
}
