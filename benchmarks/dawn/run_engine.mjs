// The browser engine's ES module run on Dawn (dawn.node, the npm package `webgpu`) without a browser.
//
//   node benchmarks/dawn/run_engine.mjs --manifest STATES/manifest.json --out result.json \
//        --dawn path/to/unpacked/webgpu/package [--seconds 5] [--profile-frames 30]
//
// STATES is written by benchmarks/browser_engine_dawn.py: engine.mjs (BrowserEngineWidget._esm), and per
// case the synced traits a BrowserEngineWidget sends (traits.json, *.bin for the byte traits) and the kernel
// engine's picture of the same state (kernel.rgba). For each case this script shows the widget once
// through a small shim (an `el`, a canvas whose WebGPU context draws into a device texture,
// requestAnimationFrame driven by this loop, the model's get/set/on/send), then
//   1. plays it: frames the GPU completed per second over --seconds (after a warm-up second);
//   2. GPU ms per pass per frame with timestamp queries around every pass (where the adapter has
//      timestamp-query; pass disable-dawn-features=timestamp_quantization is always given);
//   3. resets, pauses, runs the case's steps, draws one frame, reads it back and compares it with
//      the kernel's picture (mean |diff| over RGB in 0..255, share of pixels off by > 40).
// It prints one line per case and writes all figures as JSON (--out); the frames as .rgba beside it.

import { mkdirSync, readFileSync, writeFileSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { pathToFileURL } from "node:url";
import { performance } from "node:perf_hooks";
import { FakeElement, Model, findCanvas, installPage, page, pump, readCanvas } from "./shim.mjs";

function parseArgs(argv) {
  const args = { seconds: 5, profileFrames: 30, warmup: 1 };
  for (let k = 0; k < argv.length; k += 2) {
    const [key, value] = [argv[k].replace(/^--/, ""), argv[k + 1]];
    if (key === "manifest") args.manifest = value;
    else if (key === "out") args.out = value;
    else if (key === "dawn") args.dawn = value;
    else if (key === "seconds") args.seconds = Number(value);
    else if (key === "profile-frames") args.profileFrames = Number(value);
    else if (key === "warmup") args.warmup = Number(value);
    else throw new Error(`unknown argument --${key}`);
  }
  if (!args.manifest || !args.out || !args.dawn) throw new Error("need --manifest, --out and --dawn");
  return args;
}

const args = parseArgs(process.argv.slice(2));
const { create, globals } = await import(pathToFileURL(join(resolve(args.dawn), "index.js")).href);
Object.assign(globalThis, globals);
const gpu = create(["disable-dawn-features=timestamp_quantization"]);

installPage(gpu);

function loadState(root, c) {
  const state = JSON.parse(readFileSync(join(root, c.traits), "utf8"));
  for (const [trait, file] of Object.entries(c.byte_traits)) {
    const b = readFileSync(join(root, file));
    state[trait] = new DataView(b.buffer, b.byteOffset, b.byteLength);
  }
  state.gpu_status = { state: "", detail: "" };
  return state;
}

// ------------------------------------------------------------------ timestamp queries around every pass

const QUERIES = 512;
const profiler = { on: false, device: null, querySet: null, next: 0, passes: [] };
const AdapterProto = globalThis.GPUAdapter.prototype;
const requestDevice = AdapterProto.requestDevice;
AdapterProto.requestDevice = async function (descriptor = {}) {
  const features = [...(descriptor.requiredFeatures || [])];
  if (this.features.has("timestamp-query") && !features.includes("timestamp-query")) features.push("timestamp-query");
  const device = await requestDevice.call(this, { ...descriptor, requiredFeatures: features });
  if (device.features.has("timestamp-query")) {  // a new engine (the next case): its own query set
    profiler.device = device;
    profiler.querySet = null;
  }
  return device;
};
function wrapPass(begin, kind) {
  return function (descriptor = {}) {
    if (!profiler.on || !profiler.device || descriptor.timestampWrites || profiler.next + 2 > QUERIES) {
      return begin.call(this, descriptor);
    }
    if (!profiler.querySet) profiler.querySet = profiler.device.createQuerySet({ type: "timestamp", count: QUERIES });
    const at = profiler.next;
    profiler.next += 2;
    const record = { kind, at, labels: [] };
    profiler.passes.push(record);
    const pass = begin.call(this, { ...descriptor, timestampWrites: { querySet: profiler.querySet,
      beginningOfPassWriteIndex: at, endOfPassWriteIndex: at + 1 } });
    const setPipeline = pass.setPipeline;
    pass.setPipeline = function (pipeline) {
      const label = (pipeline.label || "?").replace(/\.wgsl/g, "").replace(/\s*\(.*\)$/, "");
      if (!record.labels.includes(label)) record.labels.push(label);
      return setPipeline.call(this, pipeline);
    };
    return pass;
  };
}
// Pipelines without a label take their shader module's (the engine labels every module), so a
// pass can be named by what it runs.
const DeviceProto = globalThis.GPUDevice.prototype;
for (const method of ["createRenderPipeline", "createRenderPipelineAsync", "createComputePipeline",
  "createComputePipelineAsync"]) {
  const original = DeviceProto[method];
  DeviceProto[method] = function (descriptor) {
    const stage = descriptor.vertex || descriptor.compute || {};
    const label = descriptor.label || (stage.module && stage.module.label) || "";
    return original.call(this, label ? { ...descriptor, label } : descriptor);
  };
}
const EncoderProto = globalThis.GPUCommandEncoder.prototype;
EncoderProto.beginComputePass = wrapPass(EncoderProto.beginComputePass, "compute");
EncoderProto.beginRenderPass = wrapPass(EncoderProto.beginRenderPass, "render");

// A pass's name: what it runs (its pipelines' labels, shortened, in order).
function passName(p) {
  return `${p.kind}: ${p.labels.join(" + ") || "(no pipeline)"}`;
}

async function readTimestamps(device) {
  const n = profiler.next;
  if (!n) return [];
  const bytes = 8 * n;
  const resolveBuf = device.createBuffer({ size: bytes, usage: GPUBufferUsage.QUERY_RESOLVE | GPUBufferUsage.COPY_SRC });
  const readBuf = device.createBuffer({ size: bytes, usage: GPUBufferUsage.MAP_READ | GPUBufferUsage.COPY_DST });
  const enc = device.createCommandEncoder();
  enc.resolveQuerySet(profiler.querySet, 0, n, resolveBuf, 0);
  enc.copyBufferToBuffer(resolveBuf, 0, readBuf, 0, bytes);
  device.queue.submit([enc.finish()]);
  await readBuf.mapAsync(GPUMapMode.READ);
  const t = new BigInt64Array(readBuf.getMappedRange().slice(0));
  readBuf.unmap(); readBuf.destroy(); resolveBuf.destroy();
  return profiler.passes.map((p) => ({ name: passName(p), ms: Number(t[p.at + 1] - t[p.at]) / 1e6 }));
}

// ------------------------------------------------------------------ driving the loop

// The loop: animation frames as fast as the engine takes them (shim.mjs's pump) until `check` holds.
let currentCanvas = null;
async function until(what, check, seconds = 120) {
  const end = performance.now() + seconds * 1000;
  while (performance.now() < end) {
    const v = check();
    if (v) return v;
    await pump(currentCanvas);
  }
  throw new Error(`timed out waiting for ${what}`);
}

// Mean |a - b| over RGB (0..255) and the share of pixels off by more than 40 in some channel
// (benchmarks/browser_engine_dawn.py's frame_difference computes the same in NumPy).
function difference(a, b) {
  let sum = 0, over = 0;
  const n = a.length / 4;
  for (let k = 0; k < n; k++) {
    let worst = 0;
    for (let c = 0; c < 3; c++) {
      const d = Math.abs(a[4 * k + c] - b[4 * k + c]);
      sum += d;
      if (d > worst) worst = d;
    }
    if (worst > 40) over += 1;
  }
  return { mean_abs: sum / (3 * n), share_over_40: over / n };
}

async function runCase(root, c, tolerance, module) {
  const model = new Model(loadState(root, c));
  const el = new FakeElement("div");
  const cleanup = module.default.initialize ? module.default.initialize({ model }) : null;
  const t0 = performance.now();
  const removeView = module.default.render({ model, el });
  const canvas = findCanvas(el);
  if (!canvas) throw new Error("the engine made no canvas");
  currentCanvas = canvas;
  const status = await until("the engine to start", () => {
    const s = model.get("gpu_status");
    return s && s.state ? s : null;
  }, 600);
  if (status.state !== "ok") throw new Error(`engine did not start: ${JSON.stringify(status)}`);
  const startMs = performance.now() - t0;
  const device = page.lastDevice;

  // 1. playing: frames completed per second (the engine counts one per completed submission, so
  // the canvas's count after the queue drains is the frames completed).
  const frames = () => canvas.grasswidgetFramesDrawn || 0;
  const warmEnd = performance.now() + 1000 * args.warmup;
  await until("the warm-up", () => performance.now() > warmEnd, args.warmup + 60);
  await device.queue.onSubmittedWorkDone();
  const f0 = frames(), s0 = performance.now();
  const end = s0 + 1000 * args.seconds;
  await until("the measured seconds", () => performance.now() > end, args.seconds + 60);
  await device.queue.onSubmittedWorkDone();
  const fps = (frames() - f0) / ((performance.now() - s0) / 1000);
  const playingStats = model.sent.filter((m) => m.msg.type === "stats").map((m) => m.msg);  // the engine's own

  // 2. GPU time per pass, one frame at a time.
  const perFrame = [];
  let profiled = false;
  if (profiler.device === device) {
    for (let k = 0; k < args.profileFrames; k++) {
      await device.queue.onSubmittedWorkDone();
      profiler.on = true; profiler.next = 0; profiler.passes = [];
      const before = frames();
      await until("a profiled frame", () => frames() > before || null, 60);
      profiler.on = false;
      await device.queue.onSubmittedWorkDone();
      perFrame.push(await readTimestamps(device));
      profiled = true;
    }
  }
  const gpuMs = {};
  for (const passes of perFrame) {
    const seen = {};
    for (const p of passes) seen[p.name] = (seen[p.name] || 0) + p.ms;
    for (const [name, ms] of Object.entries(seen)) gpuMs[name] = (gpuMs[name] || 0) + ms / perFrame.length;
  }
  const gpuTotal = Object.values(gpuMs).reduce((a, b) => a + b, 0);

  // 3. the picture: reset, paused, the case's steps, one frame, read back.
  model.set("playing", false);
  model.custom({ type: "reset" });
  model.custom({ type: "step", n: c.steps });
  model.custom({ type: "sync", id: 1 });
  await until("the steps", () => model.sent.some((s) => s.msg.type === "synced" && s.msg.id === 1), 120);
  for (let k = 0; k < 2; k++) {  // two frames drawn after the steps: the last one is the state's
    const before = frames();
    await until("a frame of the stepped state", () => frames() > before || null, 60);
  }
  await device.queue.onSubmittedWorkDone();
  // The engine's count of blades drawn in this state: a counter read-back issued after the frames above
  // (paused: every frame since the steps draws this state) and completed, none pending after it.
  const engine = [...(globalThis.__grasswidgetEngines || new Map()).values()].filter((e) => !e.closed).pop();
  let visibleStepped = null;
  if (engine && engine.stats) {
    const tState = performance.now();
    await until("the engine's counts of the stepped state",
      () => (engine.countsReadAt > tState && !engine.countsPending) || null, 120);
    visibleStepped = engine.visible ? [...engine.visible] : null;
  }
  const frame = await readCanvas(device, canvas);
  const frameFile = resolve(dirname(args.out), `${c.name}_dawn.rgba`);
  writeFileSync(frameFile, frame.rgba);
  let picture = null;
  if (c.kernel_picture) {
    const kernel = readFileSync(join(root, c.kernel_picture));
    if (kernel.length !== frame.rgba.length) throw new Error(`kernel picture ${kernel.length} bytes, frame ${frame.rgba.length}`);
    const d = difference(frame.rgba, kernel);
    picture = { ...d, tolerance_mean: tolerance.mean, tolerance_share_over_40: tolerance.share_over_40,
      pass: d.mean_abs <= tolerance.mean && d.share_over_40 <= tolerance.share_over_40 };
  }
  const engineErrors = model.sent.filter((s) => s.msg.type === "error").map((s) => s.msg.message);

  if (removeView) removeView();
  if (cleanup) cleanup();
  return {
    name: c.name, blades: c.blades, width: c.width, height: c.height, steps: c.steps,
    start_ms: Math.round(startMs), fps: Number(fps.toFixed(2)), seconds: args.seconds,
    gpu_ms_per_pass: Object.fromEntries(Object.entries(gpuMs).map(([k, v]) => [k, Number(v.toFixed(4))])),
    gpu_ms_per_frame: profiled ? Number(gpuTotal.toFixed(4)) : null, profiled_frames: perFrame.length,
    // the engine's last stats message while playing: its frames/s and blades drawn per LOD class
    engine_fps_reported: playingStats.length ? Number(playingStats[playingStats.length - 1].fps.toFixed(2)) : null,
    visible_last: playingStats.length ? playingStats[playingStats.length - 1].visible : null,
    // the engine's blades drawn per LOD class in the compared (stepped) state
    visible_stepped: visibleStepped,
    frame_file: frameFile, picture, errors: engineErrors,
  };
}

mkdirSync(dirname(resolve(args.out)), { recursive: true });
const manifestPath = resolve(args.manifest);
const root = dirname(manifestPath);
const manifest = JSON.parse(readFileSync(manifestPath, "utf8"));
const module = await import(pathToFileURL(join(root, manifest.engine)).href);
const adapter = await gpu.requestAdapter();
const info = adapter.info;
const result = {
  what: "the browser engine (BrowserEngineWidget._esm) on Dawn in node, meadow preset, playing",
  dawn: "webgpu (npm) 0.6.2",
  adapter: { vendor: info.vendor, architecture: info.architecture, device: info.device, description: info.description,
    timestamp_query: adapter.features.has("timestamp-query") },
  node: process.version,
  cases: [],
};
for (const c of manifest.cases) {
  const r = await runCase(root, c, manifest.tolerance, module);
  result.cases.push(r);
  const pic = r.picture ? `picture mean |diff| ${r.picture.mean_abs.toFixed(2)}/255, ${(100 * r.picture.share_over_40).toFixed(2)}% off by > 40: ${r.picture.pass ? "pass" : "FAIL"}` : "no kernel picture";
  console.log(`${r.name}: ${r.fps} frames/s, GPU ${r.gpu_ms_per_frame ?? "n/a"} ms/frame, start ${r.start_ms} ms; ${pic}` +
    (r.errors.length ? `; errors: ${r.errors.slice(0, 3).join(" | ")}` : ""));
}
writeFileSync(args.out, JSON.stringify(result, null, 1));
process.exit(0);
