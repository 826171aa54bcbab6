// @ts-check
// Occlusion culling and the compute rasterizer of thin blades: Python's shaders.occlusion and
// shaders.compute_raster (grasswidget.browser.browser_wgsl.BrowserShaders) executed, each an object
// of its own that the frame (passes.js) asks to encode its part.
//
// Occlusion culling: while u_cull.occlusion_phase (Python's bytes) is 1, each frame is drawn in two
// phases around a max-depth pyramid, as the kernel engine's frame does. The compute rasterizer:
// while u_cull.compute_raster is 1, the compute passes marked only_if "compute_raster" run with
// each view size's per-pixel buffers, and a resolve draw follows the ribbons.

import { hzbLayout } from "./rules.js";

/** @typedef {import("../types.js").Pipe} Pipe */
/** @typedef {import("./device.js").EngineDevice} EngineDevice */
/** @typedef {(size: number, usage: number, label: string) => GPUBuffer} MakeBuffer */

/** Sizes of a view kept with their buffers at most (views, snapshots). */
const TARGETS_KEPT = 3;

/**
 * Whether the i32 word at `offset` of Python's u_cull bytes is 1.
 * @param {import("../types.js").Bytes} cull @param {number} offset @returns {boolean}
 */
function wordIsOne(cull, offset) {
  if (!cull || cull.byteLength < offset + 4) return false;
  return new DataView(cull.buffer, cull.byteOffset, cull.byteLength).getInt32(offset, true) === 1;
}

/**
 * Keep `target` as the newest of `targets` (by key), dropping the oldest beyond TARGETS_KEPT.
 * @template T @param {Map<string, T>} targets @param {string} key @param {T} target @param {(t: T) => void} destroy
 */
function keepTarget(targets, key, target, destroy) {
  targets.set(key, target);
  while (targets.size > TARGETS_KEPT) {
    const [oldKey, old] = targets.entries().next().value;
    destroy(old);
    targets.delete(oldKey);
  }
}

/** Occlusion culling's pipelines, the pyramids of the view sizes, and its part of a frame. */
export class Occlusion {
  /**
   * The pipelines: one hzb_build.wgsl per pyramid level, the second phase's cull.wgsl, the second
   * phase's ribbons (natural and colour-by sets).
   * @param {EngineDevice} gpu @param {any} spec Python's shaders.occlusion
   * @param {(list: any[], label: string) => Promise<Pipe[]>} ribbons @returns {Promise<Occlusion>}
   */
  static async build(gpu, spec, ribbons) {
    const levels = await Promise.all(spec.hzb_levels.map((/** @type {any} */ sh, /** @type {number} */ k) =>
      gpu.computePipeline(sh, `hzb_build.wgsl (level ${k + 1})`)));
    const cull = await gpu.computePipeline(spec.cull, "cull.wgsl (occlusion, second phase)");
    const blades = await ribbons(spec.blades, "occlusion second phase, ");
    const flatBlades = await ribbons(spec.blades_flat, "occlusion second phase, colour by, ");
    return new Occlusion(gpu, spec, levels, cull, blades, flatBlades);
  }

  /**
   * @param {EngineDevice} gpu @param {any} spec @param {Pipe[]} levels @param {Pipe} cull
   * @param {Pipe[]} blades @param {Pipe[]} flatBlades
   */
  constructor(gpu, spec, levels, cull, blades, flatBlades) {
    this.gpu = gpu;
    this.spec = spec;
    this.levels = levels;
    this.cull = cull;
    this.blades = blades;
    this.flatBlades = flatBlades;
    /** @type {Map<string, {layout: number[][], hzb: GPUBuffer, table: GPUBuffer, levelGroups: GPUBindGroup[], cullGroup: GPUBindGroup}>} */
    this.targets = new Map();
  }

  /** u_cull.occlusion_phase of Python's bytes (engine_inputs.cull_uniform_values): 1 = two phases. @param {import("../types.js").Bytes} cull */
  on(cull) { return wordIsOne(cull, this.spec.phase_offset); }

  /** The second phase's draws (bound to the resources' buffers). @returns {Pipe[]} */
  boundPipes() { return [...this.blades, ...this.flatBlades]; }

  /**
   * s_occlusion_flags (one bit per blade, whole workgroups of words, all ones: every blade seen)
   * and s_occlusion_args (the second phase's draw args, then the occluded count).
   * @param {MakeBuffer} make @param {number} workgroupCount the blades' workgroups
   * @returns {Record<string, GPUBuffer>}
   */
  buffers(make, workgroupCount) {
    const U = GPUBufferUsage;
    const words = workgroupCount * this.spec.flag_words_per_workgroup;
    const flags = make(words * 4, U.STORAGE | U.COPY_DST, "occlusion flags");
    this.gpu.device.queue.writeBuffer(flags, 0, new Uint32Array(words).fill(0xFFFFFFFF));
    const args = make(this.spec.args_words * 4, U.STORAGE | U.INDIRECT | U.COPY_SRC | U.COPY_DST, "occlusion draw args");
    return { s_occlusion_flags: flags, s_occlusion_args: args };
  }

  dropTargets() {
    for (const t of this.targets.values()) { t.hzb.destroy(); t.table.destroy(); }
    this.targets.clear();
  }

  /**
   * The pyramid of a (width, height) view: its buffer (reference.hzb_layout's layout), its level
   * table, the bind groups that use them.
   * @param {number} width @param {number} height @param {Record<string, GPUBuffer>} buffers the resources'
   */
  target(width, height, buffers) {
    const key = `${width}x${height}`;
    let t = this.targets.get(key);
    if (t) { this.targets.delete(key); this.targets.set(key, t); return t; }
    const spec = this.spec;
    const layout = hzbLayout(width, height, spec.row_align);
    if (layout.length > spec.max_levels) {
      throw new Error(`occlusion culling supports views up to ${2 ** (spec.max_levels - 1)} pixels wide and high; got ${width} x ${height}`);
    }
    const U = GPUBufferUsage;
    const device = this.gpu.device;
    const last = layout[layout.length - 1];
    const hzb = device.createBuffer({ size: 4 * (last[0] + last[1] * last[2]), usage: U.STORAGE | U.COPY_DST, label: "hzb" });
    const words = new Uint32Array(4 * (spec.max_levels + 1));
    words.set([layout.length, width, height, 0]);
    layout.forEach((level, k) => words.set(level, 4 * (k + 1)));
    const table = device.createBuffer({ size: words.byteLength, usage: U.STORAGE | U.COPY_DST, label: "hzb levels" });
    device.queue.writeBuffer(table, 0, words);
    const res = { ...buffers, s_hzb: hzb, s_hzb_levels: table };
    t = { layout, hzb, table, levelGroups: this.levels.slice(0, layout.length - 1).map((p) => this.gpu.bindGroup(p, res)),
      cullGroup: this.gpu.bindGroup(this.cull, res) };
    keepTarget(this.targets, key, t, (old) => { old.hzb.destroy(); old.table.destroy(); });
    return t;
  }

  /**
   * Between the phases: the depth into the pyramid's level 0, the further levels, the second cull
   * (and the compute rasterizer's second-phase walks while it is on).
   * @param {GPUCommandEncoder} encoder @param {GPUTexture} depthTexture @param {number} width @param {number} height
   * @param {Record<string, GPUBuffer>} buffers @param {[number, number]} bladeGroups the blades' workgroups
   * @param {{raster: ComputeRaster, target: any} | null} raster
   */
  encodeSecondPhase(encoder, depthTexture, width, height, buffers, bladeGroups, raster) {
    const t = this.target(width, height, buffers);
    encoder.copyTextureToBuffer({ texture: depthTexture, aspect: "depth-only" },
      { buffer: t.hzb, bytesPerRow: 4 * t.layout[0][3], rowsPerImage: height }, [width, height]);
    const cpass = encoder.beginComputePass();
    t.levelGroups.forEach((g, k) => {
      const [, w, h] = t.layout[k + 1];
      cpass.setPipeline(this.levels[k].pipeline);
      cpass.setBindGroup(0, g);
      cpass.dispatchWorkgroups(Math.ceil(w / 8), Math.ceil(h / 8));
    });
    cpass.setPipeline(this.cull.pipeline);
    cpass.setBindGroup(0, t.cullGroup);
    cpass.dispatchWorkgroups(bladeGroups[0], bladeGroups[1]);
    if (raster) raster.raster.encodeSecondPhase(cpass, raster.target, buffers);
    cpass.end();
  }

  /**
   * The second phase's draws over the first's picture (colour and depth loaded), then the culled
   * blades (colour by cull: every test's, occlusion included); returns the pass (balls follow).
   * @param {GPUCommandEncoder} encoder @param {GPUTextureView} colorView @param {GPUTextureView} depthView
   * @param {Record<string, GPUBuffer>} buffers @param {boolean} flat the colour-by set
   * @param {Pipe | null} culled the culled blades' draw (colour by cull), or null
   * @returns {GPURenderPassEncoder}
   */
  beginDrawPass(encoder, colorView, depthView, buffers, flat, culled) {
    const pass = encoder.beginRenderPass({
      colorAttachments: [{ view: colorView, loadOp: "load", storeOp: "store" }],
      depthStencilAttachment: { view: depthView, depthLoadOp: "load", depthStoreOp: "discard" },
    });
    (flat ? this.flatBlades : this.blades).forEach((p, k) => {
      pass.setPipeline(p.pipeline);
      pass.setBindGroup(0, p.group);
      pass.drawIndirect(buffers.s_occlusion_args, 16 * k);
    });
    if (culled) {
      pass.setPipeline(culled.pipeline);
      pass.setBindGroup(0, culled.group);
      pass.drawIndirect(buffers.s_culled_args, 0);
    }
    return pass;
  }
}

/**
 * The compute rasterizer: per view size, the per-pixel depth, payload and colour words and the bind
 * groups of the passes that use them; the second phase's walks and shade; the resolve draw. The clear,
 * the walks and the shade of the first phase are compute passes of shaders.compute_passes (only_if
 * "compute_raster", "sized").
 */
export class ComputeRaster {
  /**
   * @param {EngineDevice} gpu @param {any} spec Python's shaders.compute_raster
   * @param {GPUDepthStencilState} depthStencil the ribbons' @returns {Promise<ComputeRaster>}
   */
  static async build(gpu, spec, depthStencil) {
    const second_args = await gpu.computePipeline(spec.second_args, "raster.wgsl (args, occlusion second phase)");
    const second_depth = await gpu.computePipeline(spec.second_depth, "raster.wgsl (depth, occlusion second phase)");
    const second_payload = await gpu.computePipeline(spec.second_payload, "raster.wgsl (payload, occlusion second phase)");
    const second_shade_args = await gpu.computePipeline(spec.second_shade_args, "raster.wgsl (shade_args, occlusion second phase)");
    const second_shade = await gpu.computePipeline(spec.second_shade, "raster.wgsl (shade, occlusion second phase)");
    const resolve = await gpu.renderPipeline(spec.resolve, "raster_resolve.wgsl", { topology: "triangle-strip", depth: depthStencil });
    return new ComputeRaster(gpu, spec, { second_args, second_depth, second_payload, second_shade_args, second_shade },
      resolve);
  }

  /**
   * @param {EngineDevice} gpu @param {any} spec
   * @param {{second_args: Pipe, second_depth: Pipe, second_payload: Pipe, second_shade_args: Pipe, second_shade: Pipe}} second
   * @param {Pipe} resolve
   */
  constructor(gpu, spec, second, resolve) {
    this.gpu = gpu;
    this.spec = spec;
    this.second = second;
    this.resolve = resolve;
    /** @type {Map<string, {depth: GPUBuffer, payload: GPUBuffer, color: GPUBuffer, groups: Map<string, GPUBindGroup>}>} */
    this.targets = new Map();
    /** @type {string | null} the size whose rows the counters hold */
    this.lastKey = null;
  }

  /** u_cull.compute_raster of Python's bytes (engine_inputs.compute_raster_values): 1 = on. @param {import("../types.js").Bytes} cull */
  on(cull) { return wordIsOne(cull, this.spec.switch_offset); }

  /**
   * s_raster (the listed blades), s_raster_args (counters, read by the stats) and s_raster_dispatch
   * (the walks' workgroups, written by the args step, and the clear's, by clear_args).
   * @param {MakeBuffer} make @param {number} n blades @returns {Record<string, GPUBuffer>}
   */
  buffers(make, n) {
    const U = GPUBufferUsage;
    return {
      s_raster: make(n * 4, U.STORAGE, "compute raster list"),
      s_raster_args: make(4 * this.spec.args_words, U.STORAGE | U.COPY_SRC | U.COPY_DST, "compute raster counters"),
      s_raster_dispatch: make(4 * this.spec.dispatch_words, U.STORAGE | U.INDIRECT, "compute raster walks' workgroups"),
    };
  }

  dropTargets() {
    for (const t of this.targets.values()) { t.depth.destroy(); t.payload.destroy(); t.color.destroy(); }
    this.targets.clear();
    this.lastKey = null;
  }

  /**
   * The per-pixel words of a (width, height) view and the bind groups that use them; this frame's
   * render size written into u_cull (cull.wgsl lists thin blades only in renders of that size).
   * @param {number} width @param {number} height @param {import("./resources.js").EngineResources} resources
   * @param {Pipe[] & {name: string}[]} sized the compute passes bound per size
   */
  target(width, height, resources, sized) {
    const device = this.gpu.device;
    const spec = this.spec;
    const buffers = resources.res;
    resources.writeUniform("u_cull", [[spec.width_offset, "f32", width], [spec.height_offset, "f32", height]]);
    const key = `${width}x${height}`;
    if (this.lastKey !== key) {  // the rows written were another size's: Python's spec, zeros clear the whole view
      device.queue.writeBuffer(buffers.s_raster_args, 4 * spec.rows_at, new Uint32Array(spec.rows_words));
      this.lastKey = key;
    }
    let t = this.targets.get(key);
    if (t) { this.targets.delete(key); this.targets.set(key, t); return t; }
    const U = GPUBufferUsage;
    const bytes = 4 * width * height;
    const depth = device.createBuffer({ size: bytes, usage: U.STORAGE, label: "compute raster depth" });
    const payload = device.createBuffer({ size: bytes, usage: U.STORAGE, label: "compute raster payload" });
    const color = device.createBuffer({ size: bytes * spec.color_words_per_pixel, usage: U.STORAGE,
      label: "compute raster colours" });
    const res = { ...buffers, s_raster_depth: depth, s_raster_payload: payload, s_raster_color: color };
    const groups = new Map();
    for (const p of sized) groups.set(p.name, this.gpu.bindGroup(p, res));
    for (const [name, p] of Object.entries(this.second)) groups.set(name, this.gpu.bindGroup(p, res));
    groups.set("resolve", this.gpu.bindGroup(this.resolve, res));
    t = { depth, payload, color, groups };
    keepTarget(this.targets, key, t, (old) => { old.depth.destroy(); old.payload.destroy(); old.color.destroy(); });
    return t;
  }

  /**
   * The thin blades the second phase listed, walked into the same per-pixel words, and the written
   * rows shaded again (both phases' blades).
   * @param {GPUComputePassEncoder} cpass @param {{groups: Map<string, GPUBindGroup>}} target
   * @param {Record<string, GPUBuffer>} buffers
   */
  encodeSecondPhase(cpass, target, buffers) {
    const steps = /** @type {const} */ (["second_args", "second_depth", "second_payload", "second_shade_args", "second_shade"]);
    for (const name of steps) {
      cpass.setPipeline(this.second[name].pipeline);
      cpass.setBindGroup(0, target.groups.get(name));
      // one thread: the walks' workgroups (a thread per blade this phase listed), the shade's (a thread per pixel)
      if (name === "second_args" || name === "second_shade_args") cpass.dispatchWorkgroups(1);
      else cpass.dispatchWorkgroupsIndirect(buffers.s_raster_dispatch, name === "second_shade" ? this.spec.shade_offset : 0);
    }
  }

  /**
   * The resolve: one draw across the written rows, writing the compute-drawn pixels' colours (the shade
   * step's, colour-by views included) and depths.
   * @param {GPURenderPassEncoder} pass @param {{groups: Map<string, GPUBindGroup>}} target
   */
  encodeResolve(pass, target) {
    pass.setPipeline(this.resolve.pipeline);
    pass.setBindGroup(0, target.groups.get("resolve"));
    pass.draw(4);
  }
}
