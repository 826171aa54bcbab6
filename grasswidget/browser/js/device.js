// @ts-check
// The browser engine's WebGPU device: start-up (adapter, device, limits), shader compilation with
// the compiler's messages, and the pipelines built from Python's shaders, cached by text and state.

/** @typedef {import("../types.js").Shader} Shader */
/** @typedef {import("../types.js").Pipe} Pipe */

/** A shader that does not compile: the compiler's messages ({line, column, message}). */
export class CompileError extends Error {
  /** @param {string} text @param {{line: number | null, column: number | null, message: string}[]} messages */
  constructor(text, messages) {
    super(text);
    this.messages = messages;
  }
}

/**
 * One WebGPU device of the engine and its pipeline cache. Built by {@link EngineDevice.open};
 * a lost device is not reused: the engine opens a new one.
 */
export class EngineDevice {
  /**
   * WebGPU started: an adapter and a device with the limits the shaders need.
   * @param {number} storageBuffers the most storage buffers one of Python's shaders binds (>= 8 asked)
   * @returns {Promise<EngineDevice | string>} the device, or why there is none
   */
  static async open(storageBuffers) {
    if (!navigator.gpu) return "navigator.gpu is missing";
    const adapter = await navigator.gpu.requestAdapter();
    if (!adapter) return "requestAdapter() gave null";
    /** @type {Record<string, number>} */
    const limits = {};
    for (const k of /** @type {const} */ (["maxStorageBufferBindingSize", "maxBufferSize"])) limits[k] = adapter.limits[k];
    // Occlusion culling's second pass with the compute rasterizer binds 10; WebGPU's default is 8.
    limits.maxStorageBuffersPerShaderStage = Math.min(Math.max(storageBuffers, 8), adapter.limits.maxStorageBuffersPerShaderStage);
    const device = await adapter.requestDevice({ requiredLimits: limits });
    return new EngineDevice(adapter, device);
  }

  /** @param {GPUAdapter} adapter @param {GPUDevice} device */
  constructor(adapter, device) {
    this.adapter = adapter;  // kept referenced: Chromium rejects queue promises once the adapter is collected
    this.device = device;
    this.format = navigator.gpu.getPreferredCanvasFormat();
    const info = adapter.info || /** @type {GPUAdapterInfo} */ ({});
    this.adapterText = [info.vendor, info.architecture, info.description].filter(Boolean).join(" ") || "WebGPU adapter";
    /** The pipelines of the last build ("now") and the one before, by text and state. */
    this.cache = { now: new Map(), before: new Map() };
  }

  /** A new build of pipelines begins: the last build's become "before" (switching back builds none). */
  newBuild() {
    this.cache = { now: new Map(), before: this.cache.now };
  }

  /** @param {string} key @returns {Pipe | null} */
  cached(key) {
    const hit = this.cache.now.get(key) || this.cache.before.get(key);
    if (hit) this.cache.now.set(key, hit);
    return hit || null;
  }

  /**
   * A module compiled from one rendered shader; throws a {@link CompileError} with the compiler's messages.
   * @param {Shader} shader @param {string} label @returns {Promise<GPUShaderModule>}
   */
  async compile(shader, label) {
    const device = this.device;
    device.pushErrorScope("validation");
    const module = device.createShaderModule({ code: shader.code, label });
    const info = await module.getCompilationInfo();
    const scopeError = await device.popErrorScope();
    const errors = info.messages.filter((m) => m.type === "error");
    if (errors.length || scopeError) {
      const text = `${label} does not compile: ` +
        (errors.map((m) => `line ${m.lineNum}:${m.linePos} ${m.message}`).join("; ") || scopeError.message);
      const messages = errors.length ? errors.map((m) => ({ line: m.lineNum, column: m.linePos, message: m.message }))
        : [{ line: null, column: null, message: scopeError.message }];
      throw new CompileError(text, messages);
    }
    return module;
  }

  /** @param {Shader} shader @param {number} visibility GPUShaderStage bits @returns {GPUBindGroupLayout} */
  layoutFor(shader, visibility) {
    const entries = shader.bindings.map((b) => ({ binding: b.binding, visibility, buffer: { type: b.kind } }));
    return this.device.createBindGroupLayout({ entries });
  }

  /** @param {Shader} shader @param {string} label @returns {Promise<Pipe>} */
  async computePipeline(shader, label) {
    const key = `compute\n${shader.code}`;
    const hit = this.cached(key);
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
    return this.keep(key, { pipeline, layout, shader });
  }

  /**
   * @param {Shader} shader @param {string} label
   * @param {{topology: GPUPrimitiveTopology, depth: GPUDepthStencilState, blend?: GPUBlendState}} state
   * @returns {Promise<Pipe>}
   */
  async renderPipeline(shader, label, { topology, depth, blend }) {
    const key = JSON.stringify(["render", shader.code, shader.vertex, shader.fragment, this.format, topology, depth, blend]);
    const hit = this.cached(key);
    if (hit) return { ...hit, shader };
    const module = await this.compile(shader, label);
    const layout = this.layoutFor(shader, GPUShaderStage.VERTEX | GPUShaderStage.FRAGMENT);
    const pipeline = await this.device.createRenderPipelineAsync({
      layout: this.device.createPipelineLayout({ bindGroupLayouts: [layout] }),
      vertex: { module, entryPoint: shader.vertex || "vs_main" },
      fragment: { module, entryPoint: shader.fragment || "fs_main", targets: [{ format: this.format, blend }] },
      primitive: { topology, cullMode: "none" },
      depthStencil: depth,
    });
    return this.keep(key, { pipeline, layout, shader });
  }

  /** @param {string} key @param {Pipe} pipe @returns {Pipe} */
  keep(key, pipe) {
    this.cache.now.set(key, pipe);
    return pipe;
  }

  /**
   * A bind group of `pipe` from buffers by name (a binding's `resource`, else its name).
   * @param {Pipe} pipe @param {Record<string, GPUBuffer>} buffers @returns {GPUBindGroup}
   */
  bindGroup(pipe, buffers) {
    return this.device.createBindGroup({
      layout: pipe.layout,
      entries: pipe.shader.bindings.map((b) => {
        const buffer = buffers[b.resource || b.name];
        if (!buffer) throw new Error(`the browser engine has no resource named ${b.resource || b.name}`);
        return { binding: b.binding, resource: { buffer } };
      }),
    });
  }
}
