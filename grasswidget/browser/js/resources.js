// @ts-check
// The browser engine's resources: buffers sized from Python's data, Python's packed bytes written
// into them as they are (every uniform by one route, writeUniform), and the bind groups of the pipelines.

import { workgroups } from "./rules.js";

/** @typedef {import("../types.js").Model} Model */
/** @typedef {import("./device.js").EngineDevice} EngineDevice */
/** @typedef {import("./pipelines.js").EnginePipelines} EnginePipelines */

/** @param {import("../types.js").Bytes} data @returns {Uint8Array<ArrayBuffer>} the bytes of a trait's DataView */
function bytesOf(data) { return new Uint8Array(data.buffer, data.byteOffset, data.byteLength); }

/** The buffers of one device and one blade field, and what Python's traits write into them. */
export class EngineResources {
  /** @param {EngineDevice} gpu @param {Model} model */
  constructor(gpu, model) {
    this.gpu = gpu;
    this.model = model;
    /** @type {GPUBuffer[]} every buffer made here (destroyed with the next build) */
    this.own = [];
    /** @type {Record<string, GPUBuffer>} the buffers by the names the shaders bind */
    this.res = {};
    this.n = 0;          // blades
    this.nBalls = 0;     // collider spheres drawn
    /** @type {GPUBuffer | null} the stats' counters read back */
    this.argsRead = null;
  }

  /** @returns {import("../types.js").FrameRules} */
  rules() { return this.model.get("frame_rules"); }

  /**
   * The workgroups of a dispatch of `items` threads (Python's workgroup size: frame_rules.dispatch).
   * @param {number} items @returns {[number, number]}
   */
  workgroups(items) { return workgroups(items, this.rules().dispatch); }

  /**
   * Every buffer made again for the current blades (the rest pose, Python's uniforms, colliders
   * and frustum written) and bound to `pipelines`.
   * @param {EnginePipelines} pipelines
   */
  build(pipelines) {
    const device = this.gpu.device;
    const U = GPUBufferUsage;
    const model = this.model;
    const rules = this.rules();
    this.destroy();
    /** @type {(size: number, usage: number, label: string) => GPUBuffer} */
    const buffer = (size, usage, label) => {
      const b = device.createBuffer({ size: Math.max(16, Math.ceil(size / 4) * 4), usage, label });
      this.own.push(b);
      return b;
    };
    const n = model.get("n_blades");
    const classes = pipelines.lodSegments.length;
    const shaders = model.get("shaders");
    const sizes = shaders.inspector_sizes;
    this.n = n;
    /** @type {Record<string, GPUBuffer>} */
    const res = {
      s_blades: buffer(n * rules.engine.blade_bytes, U.STORAGE | U.COPY_SRC | U.COPY_DST, "blades"),
      // the collision strengths, then the word simulate.wgsl sets when it put a non-finite blade at rest
      s_collision: buffer((n + 1) * 4, U.STORAGE | U.COPY_SRC | U.COPY_DST, "collision"),
      s_args: buffer(classes * 16, U.STORAGE | U.INDIRECT | U.COPY_SRC | U.COPY_DST, "draw args"),
      s_visible: buffer(classes * n * 4, U.STORAGE, "visible"),
      s_culled: buffer(n * 4, U.STORAGE, "culled"),
      s_culled_args: buffer(16, U.STORAGE | U.INDIRECT | U.COPY_DST, "culled draw args"),
      s_bands: buffer(2 * classes * Math.max(shaders.bands || 1, 1) * 4, U.STORAGE, "distance bands"),
      u_stdinfo: buffer(model.get("stdinfo_size"), U.UNIFORM | U.COPY_DST, "u_stdinfo"),
      u_wobject: buffer(128, U.UNIFORM | U.COPY_DST, "u_wobject"),
      s_colliders: buffer(model.get("collider_buffer_bytes")[0], U.STORAGE | U.COPY_DST, "colliders"),
      s_collider_grid: buffer(model.get("collider_buffer_bytes")[1], U.STORAGE | U.COPY_DST, "collider grid"),
      s_frustum: buffer(sizes.frustum, U.STORAGE | U.COPY_DST, "frustum lines"),
      s_segments: buffer(sizes.segments, U.STORAGE, "inspector lines"),
      s_points: buffer(sizes.points, U.STORAGE | U.COPY_SRC, "inspector points"),
      s_forces: buffer(sizes.forces, U.STORAGE | U.COPY_SRC, "inspector forces"),
    };
    // The uniforms Python packs, each from its trait (frame_rules.engine.uniforms).
    for (const [name, trait] of rules.engine.uniforms) {
      res[name] = buffer(model.get(/** @type {any} */ (trait)).byteLength, U.UNIFORM | U.COPY_DST, name);
    }
    res.s_balls = res.s_colliders;  // the balls are drawn from the colliders' buffer
    const [gx, gy] = this.workgroups(n);
    if (pipelines.occlusion) Object.assign(res, pipelines.occlusion.buffers(buffer, gx * gy));
    if (pipelines.raster) Object.assign(res, pipelines.raster.buffers(buffer, n));
    this.res = res;
    // The args of the first phase, the second's and the occluded count, the compute rasterizer's
    // counters: where Python's layout puts them (frame_rules.counters).
    this.argsRead = buffer(4 * rules.counters.words, U.MAP_READ | U.COPY_DST, "args readback");
    const identity = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];  // world_transform and its inverse
    device.queue.writeBuffer(res.u_wobject, 0, new Float32Array([...identity, ...identity]));
    this.writeRestPose();
    for (const [name] of rules.engine.uniforms) this.writeUniform(name);
    this.writeFrustum();
    this.writeBalls();
    this.bind(pipelines);
  }

  /**
   * The bind groups of `pipelines` (new pipelines, or new buffers); the per-size ones are made
   * again on demand (culling.js).
   * @param {EnginePipelines} pipelines
   */
  bind(pipelines) {
    for (const p of pipelines.boundPipes()) p.group = this.gpu.bindGroup(p, this.res);
    if (pipelines.occlusion) pipelines.occlusion.dropTargets();
    if (pipelines.raster) pipelines.raster.dropTargets();
  }

  /** The rest pose (Python's blade_data) into the blades, the collision strengths to 0. */
  writeRestPose() {
    const queue = this.gpu.device.queue;
    queue.writeBuffer(this.res.s_blades, 0, bytesOf(this.model.get("blade_data")));
    queue.writeBuffer(this.res.s_collision, 0, new Float32Array(this.n + 1));
  }

  /** The finite check's flag (after the collision strengths) back to 0, once Python has read it. */
  clearResetFlag() {
    this.gpu.device.queue.writeBuffer(this.res.s_collision, this.n * 4, new Float32Array(1));
  }

  /**
   * Python's packed bytes of a uniform (frame_rules.engine.uniforms: buffer -> trait) into its
   * buffer, as they are, with `patch`'s fields set on the way: [byte offset, "f32" or "i32", value]
   * (u_sim's per-dispatch time0 and steps at sim_layout's offsets; u_cull's render size).
   * @param {string} name the buffer (u_sim, u_cull...) @param {[number, "f32" | "i32", number][]} [patch]
   */
  writeUniform(name, patch) {
    const pair = this.rules().engine.uniforms.find(([buffer]) => buffer === name);
    if (!pair) throw new Error(`the browser engine has no uniform named ${name}`);
    let bytes = bytesOf(this.model.get(/** @type {any} */ (pair[1])));
    if (patch && patch.length) {
      bytes = bytes.slice();
      const view = new DataView(bytes.buffer);
      for (const [offset, kind, value] of patch) {
        if (kind === "f32") view.setFloat32(offset, value, true);
        else view.setInt32(offset, value, true);
      }
    }
    this.gpu.device.queue.writeBuffer(this.res[name], 0, bytes);
  }

  /**
   * u_sim's per-dispatch fields as a patch (sim_layout's offsets).
   * @param {number} time0 the wind time of the first step (s) @param {number} steps steps of this dispatch
   * @returns {[number, "f32" | "i32", number][]}
   */
  simPatch(time0, steps) {
    const layout = this.model.get("sim_layout");
    return [[layout.time0[0], "f32", time0], [layout.steps[0], "i32", steps]];
  }

  /** The buffer a trait's bytes fill (frame_rules.engine.uniforms), or null. @param {string} trait @returns {string | null} */
  uniformOf(trait) {
    const pair = this.rules().engine.uniforms.find(([, t]) => t === trait);
    return pair ? pair[0] : null;
  }

  /** The frozen camera's frustum edges (Python's core.teaching.frustum_segments), when frozen. */
  writeFrustum() {
    const data = this.model.get("frustum_lines");
    if (data.byteLength) this.gpu.device.queue.writeBuffer(this.res.s_frustum, 0, bytesOf(data));
  }

  /** The spheres and their grid, as Python built them (grasswidget.core.collider_grid). */
  writeBalls() {
    for (const [name, trait] of [["s_colliders", "collider_spheres"], ["s_collider_grid", "collider_grid"]]) {
      const data = this.model.get(/** @type {"collider_spheres" | "collider_grid"} */ (trait));
      if (data && data.byteLength) this.gpu.device.queue.writeBuffer(this.res[name], 0, bytesOf(data));
    }
    const grid = this.model.get("collider_grid");  // word 2: the number of spheres
    this.nBalls = grid && grid.byteLength >= 12 ? new DataView(grid.buffer, grid.byteOffset, grid.byteLength).getUint32(8, true) : 0;
  }

  destroy() {
    for (const b of this.own) b.destroy();
    this.own = [];
  }
}
