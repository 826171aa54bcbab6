// @ts-check
// The answers to Python's requests that read the GPU back: the state, the inspected blades, a
// picture. The requests themselves are GrassEngine's message table (engine.js), kind -> handler:
//   step {n}, reset, clear_reset_flag, read_state {id}, snapshot {id, width, height, filter}
//   (filter: grasswidget.core.engine_inputs.export_filter, the supersampling), read_inspected {id},
//   sync {id} (answered at once: "synced"), compile_simulate {id, shader, passes}, lose_device (tests).
// Answers and reports: state, snapshot, inspected, compiled, synced, stats, steps, pick, ball, key,
//   rest (no view on screen: nothing is drawn until one is), error and device_lost messages; the
//   gpu_status trait.

import { downsample } from "./pictures.js";

/** @typedef {import("../types.js").Model} Model */
/** @typedef {import("./device.js").EngineDevice} EngineDevice */
/** @typedef {import("./resources.js").EngineResources} EngineResources */
/** @typedef {import("./pipelines.js").EnginePipelines} EnginePipelines */
/** @typedef {import("./passes.js").FramePasses} FramePasses */

/** @param {GPUDevice} device @param {number} size @returns {GPUBuffer} a buffer to read back into */
function readback(device, size) {
  return device.createBuffer({ size, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
}

/**
 * The blades and the collision strengths (with the reset flag) as they are now, sent as "state".
 * @param {EngineDevice} gpu @param {EngineResources} resources @param {Model} model @param {number} id
 * @param {number} steps the steps the state is of
 */
export async function readState(gpu, resources, model, id, steps) {
  const device = gpu.device;
  const res = resources.res;
  const a = readback(device, res.s_blades.size);
  const b = readback(device, res.s_collision.size);
  const encoder = device.createCommandEncoder();
  encoder.copyBufferToBuffer(res.s_blades, 0, a, 0, a.size);
  encoder.copyBufferToBuffer(res.s_collision, 0, b, 0, b.size);
  device.queue.submit([encoder.finish()]);
  await Promise.all([a.mapAsync(GPUMapMode.READ), b.mapAsync(GPUMapMode.READ)]);
  const n = resources.n;
  const blades = a.getMappedRange().slice(0, n * model.get("frame_rules").engine.blade_bytes);
  const collision = b.getMappedRange().slice(0, (n + 1) * 4);  // the strengths and the reset flag
  a.destroy(); b.destroy();
  model.send({ type: "state", id, step_count: steps, n }, undefined, [blades, collision]);
}

/**
 * The inspected blades' forces (vec4 each) and control points, computed now by the inspector's
 * passes for the current state and parameters (as gpu.inspector.BladeInspector.read), sent as "inspected".
 * @param {EngineDevice} gpu @param {EnginePipelines} pipelines @param {EngineResources} resources
 * @param {Model} model @param {number} id @param {number} steps the steps the state is of
 * @param {() => void} writeSimNow u_sim for "now"
 */
export async function readInspected(gpu, pipelines, resources, model, id, steps, writeSimNow) {
  const device = gpu.device;
  const res = resources.res;
  const n = (model.get("inspected") || []).length;
  const passes = pipelines.computePasses.filter((p) => p.onlyIf === "inspecting");
  const forcesBytes = model.get("frame_rules").engine.inspected_force_bytes * n;
  const pointsBytes = model.get("frame_rules").engine.inspected_point_bytes * n;
  const a = readback(device, Math.max(16, forcesBytes));
  const b = readback(device, Math.max(16, Math.ceil(pointsBytes / 4) * 4 + 4));
  const encoder = device.createCommandEncoder();
  if (n > 0) {
    const cpass = encoder.beginComputePass();
    for (const p of passes) {
      if (p.simNow) writeSimNow();
      cpass.setPipeline(p.pipeline);
      cpass.setBindGroup(0, p.group);
      cpass.dispatchWorkgroups(1);
    }
    cpass.end();
    encoder.copyBufferToBuffer(res.s_forces, 0, a, 0, forcesBytes);
    encoder.copyBufferToBuffer(res.s_points, 0, b, 0, Math.ceil(pointsBytes / 4) * 4);
  }
  device.queue.submit([encoder.finish()]);
  await Promise.all([a.mapAsync(GPUMapMode.READ), b.mapAsync(GPUMapMode.READ)]);
  const forces = a.getMappedRange().slice(0, forcesBytes);
  const points = b.getMappedRange().slice(0, pointsBytes);
  a.destroy(); b.destroy();
  model.send({ type: "inspected", id, n, step_count: steps }, undefined, [forces, points]);
}

/**
 * A picture of the current state at msg.width x msg.height, rendered msg.filter.factor times
 * larger and filtered down (Python's export_filter; factor 1 when absent or when the larger
 * picture would exceed the device's texture limit), sent as "snapshot".
 * @param {EngineDevice} gpu @param {FramePasses} frame @param {Model} model
 * @param {{id: number, width: number, height: number, filter?: {factor: number, first: number, weights: number[]}}} msg
 */
export async function snapshot(gpu, frame, model, msg) {
  const device = gpu.device;
  const w = msg.width, h = msg.height;
  let filter = msg.filter || { factor: 1, first: 0, weights: [1] };
  if (Math.max(w, h) * filter.factor > device.limits.maxTextureDimension2D) filter = { factor: 1, first: 0, weights: [1] };
  const sw = w * filter.factor, sh = h * filter.factor;
  const color = device.createTexture({ size: [sw, sh], format: gpu.format,
    usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
  const depth = frame.depthFor(sw, sh);
  const row = Math.ceil((sw * 4) / 256) * 256;
  const out = readback(device, row * sh);
  const encoder = device.createCommandEncoder();
  frame.encode(encoder, color.createView(), depth, sw, sh);
  encoder.copyTextureToBuffer({ texture: color }, { buffer: out, bytesPerRow: row }, [sw, sh]);
  device.queue.submit([encoder.finish()]);
  await out.mapAsync(GPUMapMode.READ);
  const src = new Uint8Array(out.getMappedRange());
  const bgra = gpu.format.startsWith("bgra");
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
  model.send({ type: "snapshot", id: msg.id, width: w, height: h, supersample: filter.factor }, undefined, [/** @type {ArrayBuffer} */ (rgba.buffer)]);
}
