// @ts-check
// The pipelines of a frame, built from the shaders Python sent (the "shaders" trait): the
// simulation, the compute passes in Python's order, the ribbon draws, sky and ground, the balls,
// the overlays, and occlusion culling's and the compute rasterizer's own (culling.js).

import { ComputeRaster, Occlusion } from "./culling.js";

/** @typedef {import("../types.js").Pipe} Pipe */
/** @typedef {import("../types.js").ComputePass} ComputePass */
/** @typedef {import("../types.js").Shaders} Shaders */
/** @typedef {import("./device.js").EngineDevice} EngineDevice */

/** The translucent balls' blend. */
const BALL_BLEND = /** @type {GPUBlendState} */ ({
  color: { srcFactor: "src-alpha", dstFactor: "one-minus-src-alpha", operation: "add" },
  alpha: { srcFactor: "one", dstFactor: "one-minus-src-alpha", operation: "add" },
});

/** Every pipeline of a frame for one set of Python's shaders (a new set: a new EnginePipelines). */
export class EnginePipelines {
  /**
   * Build the pipelines of `shaders` on `gpu` (texts built before come from its cache).
   * @param {EngineDevice} gpu @param {Shaders} shaders @returns {Promise<EnginePipelines>}
   */
  static async build(gpu, shaders) {
    gpu.newBuild();
    const depthFormat = /** @type {GPUTextureFormat} */ ((shaders.occlusion && shaders.occlusion.depth_format) || "depth24plus");
    /** @type {GPUDepthStencilState} */
    const depthStencil = { format: depthFormat, depthWriteEnabled: true, depthCompare: "less" };
    /** @type {GPUDepthStencilState} */
    const underDepth = { format: depthFormat, depthWriteEnabled: false, depthCompare: "less" };
    /** The ribbon draws of a list of LOD classes. @param {any[]} list @param {string} label @returns {Promise<Pipe[]>} */
    const ribbons = async (list, label) => {
      const pipes = [];
      for (let k = 0; k < list.length; k++) {
        pipes.push(await gpu.renderPipeline(list[k], `blade_render.wgsl (${label}class ${k})`,
          { topology: "triangle-strip", depth: depthStencil }));
      }
      return pipes;
    };
    const sim = await gpu.computePipeline(shaders.simulate, "simulate.wgsl");
    /** @type {ComputePass[]} */
    const computePasses = [];
    for (const pass of shaders.compute_passes) {
      const pipe = await gpu.computePipeline(shaders[pass.shader], pass.label || pass.shader);
      computePasses.push({ ...pipe, dispatch: pass.dispatch, name: pass.shader, label: pass.label || pass.shader,
        onlyIf: pass.only_if, simNow: pass.sim_uniform === "now", sized: !!pass.sized,
        indirectOffset: pass.indirect_offset || 0 });
    }
    // Two sets of ribbons: the natural view's, and the colour-by views' (flat colours and the
    // culled blades' draw), which cost GPU draw time and are only used while color_by shows them.
    const bladePipes = await ribbons(shaders.blades, "");
    const flatBladePipes = shaders.blades_flat ? await ribbons(shaders.blades_flat, "colour by, ") : bladePipes;
    // After the opaque grass, at the far depth with "less": only uncovered pixels are shaded.
    const skyGround = await gpu.renderPipeline(shaders.sky_ground, "sky_ground.wgsl", { topology: "triangle-strip", depth: underDepth });
    const balls = await gpu.renderPipeline({ ...shaders.balls, vertex: "vs_ball", fragment: "fs_ball" }, "balls.wgsl",
      { topology: "triangle-list", depth: underDepth, blend: BALL_BLEND });
    const occlusion = shaders.occlusion ? await Occlusion.build(gpu, shaders.occlusion, ribbons) : null;
    const raster = shaders.compute_raster ? await ComputeRaster.build(gpu, shaders.compute_raster, depthStencil) : null;
    // Lines and points over the meadow (overlay.wgsl): a quad per item, `instances` items.
    const overlays = [];
    for (const o of shaders.overlays || []) {
      /** @type {GPUDepthStencilState} */
      const depth = { format: depthFormat, depthWriteEnabled: false, depthCompare: o.depth_test ? "less" : "always" };
      const pipe = await gpu.renderPipeline(o, `overlay.wgsl (${o.name})`, { topology: "triangle-list", depth });
      overlays.push({ ...pipe, instances: /** @type {number} */ (o.instances), onlyIf: /** @type {string} */ (o.only_if) });
    }
    return new EnginePipelines({ lodSegments: shaders.lod_segments, depthFormat, sim, computePasses, bladePipes,
      flatBladePipes, skyGround, balls, overlays, occlusion, raster });
  }

  /**
   * @param {{lodSegments: number[], depthFormat: GPUTextureFormat, sim: Pipe, computePasses: ComputePass[],
   *   bladePipes: Pipe[], flatBladePipes: Pipe[], skyGround: Pipe, balls: Pipe,
   *   overlays: (Pipe & {instances: number, onlyIf: string})[], occlusion: Occlusion | null,
   *   raster: ComputeRaster | null}} parts
   */
  constructor(parts) {
    this.lodSegments = parts.lodSegments;  // segments per LOD class
    this.depthFormat = parts.depthFormat;
    this.sim = parts.sim;
    this.computePasses = parts.computePasses;
    this.bladePipes = parts.bladePipes;
    this.flatBladePipes = parts.flatBladePipes;
    this.skyGround = parts.skyGround;
    this.balls = parts.balls;
    this.overlays = parts.overlays;
    this.occlusion = parts.occlusion;
    this.raster = parts.raster;
  }

  /** The pipes bound to the resources' buffers alone (the per-size ones: culling.js). @returns {Pipe[]} */
  boundPipes() {
    return [this.sim, ...this.computePasses.filter((q) => !q.sized), ...this.bladePipes, ...this.flatBladePipes,
      this.skyGround, this.balls, ...this.overlays, ...(this.occlusion ? this.occlusion.boundPipes() : [])];
  }

  /**
   * A compiled wind swapped in (compile_simulate): the simulation and the compute passes by name
   * that compile the same wind, all compiled before any is swapped; throws (nothing swapped) when
   * one does not compile.
   * @param {EngineDevice} gpu @param {import("../types.js").Shader} shader @param {Record<string, any>} passes
   */
  async swapSimulate(gpu, shader, passes) {
    const sim = await gpu.computePipeline(shader, "simulate.wgsl");
    /** @type {[ComputePass, Pipe][]} */
    const swaps = [];
    for (const [name, pass] of Object.entries(passes || {})) {
      for (const p of this.computePasses.filter((q) => q.name === name)) swaps.push([p, await gpu.computePipeline(pass, p.label)]);
    }
    this.sim = sim;
    for (const [p, pipe] of swaps) Object.assign(p, pipe);
  }
}
