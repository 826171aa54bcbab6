// The browser engine's resources: buffers sized from Python's data, Python's packed bytes written
// into them as they are, and the bind groups of every pipeline.

import { EngineDevice } from "./device.js";
import { workgroups } from "./rules.js";

/** Uniform buffers filled with Python's packed bytes: [buffer name, trait]. */
export const UNIFORM_TRAITS = [
  ["u_cull", "cull_uniform"], ["u_material", "material_uniform"], ["u_sky_ground", "sky_ground_uniform"],
  ["u_balls", "ball_uniform"], ["u_inspect", "inspect_uniform"],
];

/** Buffers, uniforms and bind groups (the device and pipelines: EngineDevice). */
export class EngineResources extends EngineDevice {
  /**
   * The workgroups of a dispatch of `items` threads (Python's workgroup size: frame_rules.dispatch).
   * @param {number} items @returns {[number, number]}
   */
  workgroups(items) { return workgroups(items, this.rules().dispatch); }

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
      // the collision strengths, then the word simulate.wgsl sets when it put a non-finite blade at rest
      s_collision: buffer((n + 1) * 4, U.STORAGE | U.COPY_SRC | U.COPY_DST, "collision"),
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
    // The args of the first phase, the second's and the occluded count, the compute rasterizer's
    // counters: where Python's layout puts them (frame_rules.counters).
    this.argsRead = buffer(4 * this.rules().counters.words, U.MAP_READ | U.COPY_DST, "args readback");
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
    this.device.queue.writeBuffer(this.res.s_collision, 0, new Float32Array(this.n + 1));
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
}
