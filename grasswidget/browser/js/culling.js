// Occlusion culling and the compute rasterizer of thin blades: Python's shaders.occlusion and
// shaders.compute_raster (grasswidget.browser.browser_wgsl.BrowserShaders) executed. Kept apart from the
// rest of the engine: buildPipelines, buildBuffers, makeBindGroups and encodeFrame call in here.
//
// Occlusion culling: while u_cull.occlusion_phase (Python's bytes) is 1, each frame is drawn in two
// phases around a max-depth pyramid, as the kernel engine's frame does. The compute rasterizer:
// while u_cull.compute_raster is 1, the compute passes marked only_if "compute_raster" run with
// each view size's per-pixel buffers, and a resolve draw follows the ribbons.

import { EngineResources } from "./resources.js";
import { hzbLayout } from "./rules.js";

/** The occlusion culling's and the compute rasterizer's pipelines, buffers and passes. */
export class EngineCulling extends EngineResources {
  // ---------------------------------------------------------------- occlusion culling
  // Python's shaders.occlusion (grasswidget.browser.browser_wgsl.BrowserShaders.occlusion) executed: the
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

  // u_cull.occlusion_phase of Python's bytes (engine_inputs.cull_uniform_values): 1 = two phases.
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
      for (const name of ["second_args", "second_depth", "second_payload"]) {
        cpass.setPipeline(this.raster[name].pipeline);
        cpass.setBindGroup(0, raster.groups.get(name));
        if (name === "second_args") cpass.dispatchWorkgroups(1);  // a thread per blade this phase listed
        else cpass.dispatchWorkgroupsIndirect(this.res.s_raster_dispatch, 0);
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

  // The stats' readback where Python's layout (frame_rules.counters) puts it: the first phase's
  // args, the second's with the occluded count, the compute rasterizer's counters.
  encodeArgsRead(encoder) {
    const at = this.rules().counters;
    encoder.copyBufferToBuffer(this.res.s_args, 0, this.argsRead, 4 * at.first_at, 16 * this.lodSegments.length);
    if (this.occlusion) {
      encoder.copyBufferToBuffer(this.res.s_occlusion_args, 0, this.argsRead, 4 * at.second_at, 4 * this.occlusion.spec.args_words);
    }
    if (this.raster) {
      encoder.copyBufferToBuffer(this.res.s_raster_args, 0, this.argsRead, 4 * at.raster_at, 4 * this.raster.spec.args_words);
    }
  }

  // ---------------------------------------------------------------- compute rasterizer
  // Python's shaders.compute_raster (grasswidget.browser.browser_wgsl.BrowserShaders.compute_raster)
  // executed: per view size, the per-pixel depth and payload words and the bind groups of the
  // passes that use them; the resolve draw. The clear and the walks are compute passes of
  // shaders.compute_passes (only_if "compute_raster", "sized").

  async buildRasterPipelines(spec, depthStencil) {
    const second_args = await this.computePipeline(spec.second_args, "raster.wgsl (args, occlusion second phase)");
    const second_depth = await this.computePipeline(spec.second_depth, "raster.wgsl (depth, occlusion second phase)");
    const second_payload = await this.computePipeline(spec.second_payload, "raster.wgsl (payload, occlusion second phase)");
    const resolve = await this.renderPipeline(spec.resolve, "raster_resolve.wgsl", { topology: "triangle-strip", depth: depthStencil });
    const resolveFlat = await this.renderPipeline(spec.resolve_flat, "raster_resolve.wgsl (colour by)",
      { topology: "triangle-strip", depth: depthStencil });
    return { spec, second_args, second_depth, second_payload, resolve, resolveFlat, targets: new Map() };
  }

  // u_cull.compute_raster of Python's bytes (engine_inputs.compute_raster_values): 1 = on.
  rasterOn() {
    if (!this.raster) return false;
    const cu = this.model.get("cull_uniform");
    const at = this.raster.spec.switch_offset;
    if (!cu || cu.byteLength < at + 4) return false;
    return new DataView(cu.buffer, cu.byteOffset, cu.byteLength).getInt32(at, true) === 1;
  }

  // s_raster (the listed blades), s_raster_args (counters, read by the stats) and
  // s_raster_dispatch (the walks' workgroups, written by the args step, and the clear's, by clear_args).
  buildRasterBuffers(buffer) {
    const U = GPUBufferUsage;
    this.res.s_raster = buffer(this.n * 4, U.STORAGE, "compute raster list");
    this.res.s_raster_args = buffer(4 * this.raster.spec.args_words, U.STORAGE | U.COPY_SRC | U.COPY_DST,
      "compute raster counters");
    this.res.s_raster_dispatch = buffer(4 * this.raster.spec.dispatch_words, U.STORAGE | U.INDIRECT,
      "compute raster walks' workgroups");
  }

  dropRasterTargets() {
    for (const t of this.raster.targets.values()) { t.depth.destroy(); t.payload.destroy(); }
    this.raster.targets.clear();
    this.raster.lastKey = null;
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
    if (r.lastKey !== key) {  // the rows written were another size's: Python's spec, zeros clear the whole view
      this.device.queue.writeBuffer(this.res.s_raster_args, 4 * r.spec.rows_at, new Uint32Array(r.spec.rows_words));
      r.lastKey = key;
    }
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
    for (const name of ["second_args", "second_depth", "second_payload"]) groups.set(name, group(r[name]));
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
}
