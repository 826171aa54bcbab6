// @ts-check
// The passes of a frame: the simulation's fixed steps (Simulation), and one frame of the current
// state encoded for a view (FramePasses): Python's compute passes (culling, LOD binning, draw
// order), the ribbon, sky-and-ground, ball and overlay draws, occlusion culling's second phase and
// the compute rasterizer's resolve (culling.js) while they are on.

import { stepsPerDispatch, windTime } from "./rules.js";
import { invert4 } from "./linalg.js";

/** @typedef {import("../types.js").Model} Model */
/** @typedef {import("../types.js").Pipe} Pipe */
/** @typedef {import("./device.js").EngineDevice} EngineDevice */
/** @typedef {import("./pipelines.js").EnginePipelines} EnginePipelines */
/** @typedef {import("./resources.js").EngineResources} EngineResources */
/** @typedef {import("./camera.js").CameraRig} CameraRig */

/** The simulation's dispatches: exactly n fixed steps of dt, like GrassField.step. */
export class Simulation {
  /** @param {EngineDevice} gpu @param {EnginePipelines} pipelines @param {EngineResources} resources @param {Model} model */
  constructor(gpu, pipelines, resources, model) {
    this.gpu = gpu;
    this.pipelines = pipelines;
    this.resources = resources;
    this.model = model;
  }

  /** The wind time (s) of step k: (k dt) mod wind_period (Python's engine_inputs.wind_time). @param {number} k */
  windTime(k) { return windTime(k, this.model.get("frame_rules").clock); }

  /**
   * u_sim for "now": the current parameters at the time of step `stepCount`, no steps (what the
   * kernel's inspector writes before its pass: gpu.inspector.refresh_uniforms).
   * @param {number} stepCount
   */
  writeNow(stepCount) {
    this.resources.writeUniform("u_sim", this.resources.simPatch(this.windTime(stepCount), 0));
  }

  /**
   * `n` steps from step `stepCount`, in dispatches of at most Python's steps per dispatch.
   * @param {number} n @param {number} stepCount
   */
  run(n, stepCount) {
    if (n <= 0) return;
    const device = this.gpu.device;
    const resources = this.resources;
    const sim = this.pipelines.sim;
    const dispatch = this.model.get("frame_rules").dispatch;
    const perDispatch = stepsPerDispatch(resources.n, dispatch);
    const [gx, gy] = resources.workgroups(resources.n);
    let done = 0;
    while (done < n) {
      const chunk = Math.min(perDispatch, n - done);
      resources.writeUniform("u_sim", resources.simPatch(this.windTime(stepCount + done), chunk));
      const encoder = device.createCommandEncoder();
      const pass = encoder.beginComputePass();
      pass.setPipeline(sim.pipeline);
      pass.setBindGroup(0, sim.group);
      pass.dispatchWorkgroups(gx, gy);
      pass.end();
      device.queue.submit([encoder.finish()]);
      done += chunk;
    }
  }
}

/** One frame of the current state encoded for a view of a given size. */
export class FramePasses {
  /**
   * @param {{gpu: EngineDevice, pipelines: EnginePipelines, resources: EngineResources, rig: CameraRig,
   *   model: Model, active: (condition: string | undefined) => boolean, writeSimNow: () => void}} parts
   *   `active`: whether a pass or overlay with this "only_if" runs now; `writeSimNow`: u_sim for "now"
   */
  constructor({ gpu, pipelines, resources, rig, model, active, writeSimNow }) {
    this.gpu = gpu;
    this.pipelines = pipelines;
    this.resources = resources;
    this.rig = rig;
    this.model = model;
    this.active = active;
    this.writeSimNow = writeSimNow;
  }

  /** Whether occlusion culling's two phases run (Python's u_cull word). */
  occlusionOn() {
    const o = this.pipelines.occlusion;
    return !!o && o.on(this.model.get("cull_uniform"));
  }

  /** Whether the compute rasterizer runs (Python's u_cull word). */
  rasterOn() {
    const r = this.pipelines.raster;
    return !!r && r.on(this.model.get("cull_uniform"));
  }

  /** Whether the colour-by ribbons draw (u_cull.color_by, at shaders.color_by_offset, is not 0: natural). */
  flat() {
    const off = this.model.get("shaders").color_by_offset;
    const cu = this.model.get("cull_uniform");
    const colorBy = off === undefined ? 1 : new DataView(cu.buffer, cu.byteOffset, cu.byteLength).getInt32(off, true);
    return colorBy !== 0 && this.pipelines.flatBladePipes !== this.pipelines.bladePipes;
  }

  /**
   * The depth texture of a (width, height) target (COPY_SRC: occlusion culling copies it into its pyramid).
   * @param {number} width @param {number} height @returns {GPUTexture}
   */
  depthFor(width, height) {
    return this.gpu.device.createTexture({ size: [width, height], format: this.pipelines.depthFormat,
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
  }

  /** The camera uniform (pygfx's StdInfo) at the offsets Python's layout gives. @param {number} width @param {number} height */
  writeStdInfo(width, height) {
    const { world, view, proj } = this.rig.matrices(width / height);
    const at = this.model.get("stdinfo_layout");
    const f = new Float32Array(this.model.get("stdinfo_size") / 4);
    /** @param {string} name @param {ArrayLike<number>} values */
    const put = (name, values) => f.set(values, at[name][0] / 4);
    put("cam_transform", view); put("cam_transform_inv", world);
    put("projection_transform", proj); put("projection_transform_inv", invert4(proj));
    put("physical_size", [width, height]); put("logical_size", [width, height]);
    put("ndc_offset", [1, 1, 0, 0]);
    this.gpu.device.queue.writeBuffer(this.resources.res.u_stdinfo, 0, f);
  }

  /**
   * Encode one frame of the current state into a colour view of (width, height): Python's
   * compute passes (culling) for this view's camera, then the draws. Submit before the next call
   * (the camera uniform is written now, for this encoder).
   * @param {GPUCommandEncoder} encoder @param {GPUTextureView} colorView @param {GPUTexture} depthTexture
   * @param {number} width @param {number} height
   */
  encode(encoder, colorView, depthTexture, width, height) {
    const { pipelines, resources } = this;
    const res = resources.res;
    this.writeStdInfo(width, height);
    const twoPhases = this.occlusionOn();
    const sized = pipelines.computePasses.filter((q) => q.sized);
    const raster = this.rasterOn() ? pipelines.raster.target(width, height, resources, sized) : null;
    const flat = this.flat();
    const depthView = depthTexture.createView();
    const blades = resources.workgroups(resources.n);
    const cpass = encoder.beginComputePass();
    for (const p of pipelines.computePasses) {
      if (!this.active(p.onlyIf)) continue;
      if (p.simNow) this.writeSimNow();
      cpass.setPipeline(p.pipeline);
      cpass.setBindGroup(0, p.sized ? raster.groups.get(p.name) : p.group);
      if (p.dispatch === "blades") cpass.dispatchWorkgroups(blades[0], blades[1]);
      else if (p.dispatch === "raster_listed") cpass.dispatchWorkgroupsIndirect(res.s_raster_dispatch, p.indirectOffset);
      else cpass.dispatchWorkgroups(1);
    }
    cpass.end();
    const pass = encoder.beginRenderPass({
      colorAttachments: [{ view: colorView, loadOp: "clear", storeOp: "store", clearValue: { r: 0, g: 0, b: 0, a: 1 } }],
      depthStencilAttachment: { view: depthView, depthLoadOp: "clear", depthClearValue: 1,
        depthStoreOp: twoPhases ? "store" : "discard" },
    });
    const ribbons = flat ? pipelines.flatBladePipes : pipelines.bladePipes;
    ribbons.forEach((p, k) => {
      if (p.shader.culled && twoPhases) return;  // the culled blades are listed by the second phase
      pass.setPipeline(p.pipeline);
      pass.setBindGroup(0, p.group);
      if (p.shader.culled) pass.drawIndirect(res.s_culled_args, 0);  // color_by "cull": the culled blades
      else pass.drawIndirect(res.s_args, 16 * k);
    });
    if (raster) pipelines.raster.encodeResolve(pass, raster);
    pass.setPipeline(pipelines.skyGround.pipeline);
    pass.setBindGroup(0, pipelines.skyGround.group);
    pass.draw(4);
    if (twoPhases) {
      pass.end();
      const o = pipelines.occlusion;
      o.encodeSecondPhase(encoder, depthTexture, width, height, res, blades, raster ? { raster: pipelines.raster, target: raster } : null);
      const culled = flat ? pipelines.flatBladePipes.find((p) => p.shader.culled) || null : null;
      const second = o.beginDrawPass(encoder, colorView, depthView, res, flat, culled);
      if (raster) pipelines.raster.encodeResolve(second, raster);
      this.encodeBalls(second);
      return;
    }
    this.encodeBalls(pass);
  }

  /** The translucent collider balls (after every blade), the overlays, then the pass ends. @param {GPURenderPassEncoder} pass */
  encodeBalls(pass) {
    const { pipelines, resources } = this;
    if (resources.nBalls > 0 && this.model.get("show_colliders")) {
      pass.setPipeline(pipelines.balls.pipeline);
      pass.setBindGroup(0, pipelines.balls.group);
      pass.draw(this.model.get("frame_rules").engine.ball_vertices, resources.nBalls);
    }
    for (const o of pipelines.overlays) {
      if (!this.active(o.onlyIf)) continue;
      pass.setPipeline(o.pipeline);
      pass.setBindGroup(0, o.group);
      pass.draw(6, o.instances);
    }
    pass.end();
  }

  /**
   * The counters the stats read, copied where Python's layout (frame_rules.counters) puts them:
   * the first phase's args, the second's with the occluded count, the compute rasterizer's.
   * @param {GPUCommandEncoder} encoder
   */
  encodeCounters(encoder) {
    const { pipelines, resources } = this;
    const at = this.model.get("frame_rules").counters;
    const res = resources.res;
    encoder.copyBufferToBuffer(res.s_args, 0, resources.argsRead, 4 * at.first_at, 16 * pipelines.lodSegments.length);
    if (pipelines.occlusion) {
      encoder.copyBufferToBuffer(res.s_occlusion_args, 0, resources.argsRead, 4 * at.second_at, 4 * pipelines.occlusion.spec.args_words);
    }
    if (pipelines.raster) {
      encoder.copyBufferToBuffer(res.s_raster_args, 0, resources.argsRead, 4 * at.raster_at, 4 * pipelines.raster.spec.args_words);
    }
  }
}
