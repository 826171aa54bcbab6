// The browser engine's ES module on Dawn in node, as a page with Python as its kernel: the widget's
// comm runs over this process's stdin / stdout, one JSON object a line, so the Python widget
// (grasswidget.browser.engine_widget.BrowserEngineWidget, with everything it decides: the "auto" switches'
// trials and decisions, the u_cull words the engine executes) answers the engine's messages as it
// does in a notebook. Python's side: benchmarks/browser_engine_dawn.py (DawnPage).
//
//   node benchmarks/dawn/serve_engine.mjs --engine ENGINE.mjs --dawn path/to/unpacked/webgpu/package
//
// Python -> node (stdin), the Jupyter widget protocol's comm messages, binary buffers in base64:
//   {"op": "open", "comm_id", "data": {"state", "buffer_paths"}, "buffers": [b64...]}
//        a widget model: the module's initialize() and render() (one view, on screen) run for it
//   {"op": "msg", "comm_id", "data": {"method": "update" | "echo_update" | "custom", ...}, "buffers"}
//   {"op": "close", "comm_id"}            the view removed, the engine closed
//   {"op": "info", "id"}                  answered with the newest engine's counters (below)
//   {"op": "exit"}
// node -> Python (stdout; lines that start with "@gw ", anything else is the module's own output):
//   {"op": "ready", "adapter": {...}}
//   {"op": "msg", "comm_id", "data": {"method": "update", "state", "buffer_paths": []}}  save_changes()
//   {"op": "msg", "comm_id", "data": {"method": "custom", "content"}, "buffers": [b64...]}  model.send()
//   {"op": "info", "id", "info": {frames, now, n, visible, occluded, rastered, counts_switches, counts_read_at,
//                                  counts_pending, ...}}
//   {"op": "error", "message"}            an uncaught error (the process then exits with 1)
// The loop runs the animation frames the engine asks for as fast as it takes them (shim.mjs's pump).

import { createInterface } from "node:readline";
import { join, resolve } from "node:path";
import { pathToFileURL } from "node:url";
import { performance } from "node:perf_hooks";
import { FakeElement, Model, findCanvas, installPage, pump } from "./shim.mjs";

const args = { engine: null, dawn: null };
const argv = process.argv.slice(2);
for (let k = 0; k < argv.length; k += 2) {
  const key = argv[k].replace(/^--/, "");
  if (!(key in args)) throw new Error(`unknown argument --${key}`);
  args[key] = argv[k + 1];
}
if (!args.engine || !args.dawn) throw new Error("need --engine and --dawn");

function emit(obj) { process.stdout.write(`@gw ${JSON.stringify(obj)}\n`); }
function fail(err) {
  emit({ op: "error", message: String((err && err.stack) || err) });
  process.exit(1);
}
process.on("uncaughtException", fail);
process.on("unhandledRejection", fail);

const { create, globals } = await import(pathToFileURL(join(resolve(args.dawn), "index.js")).href);
Object.assign(globalThis, globals);
const gpu = create(["disable-dawn-features=timestamp_quantization"]);
installPage(gpu);
const module = await import(pathToFileURL(resolve(args.engine)).href);

// ------------------------------------------------------------------ binary buffers <-> base64

function toBase64(b) {
  if (b instanceof ArrayBuffer) return Buffer.from(b).toString("base64");
  return Buffer.from(b.buffer, b.byteOffset, b.byteLength).toString("base64");
}
function fromBase64(text) {
  const b = Buffer.from(text, "base64");
  return new DataView(b.buffer, b.byteOffset, b.byteLength);  // as anywidget hands binary traits to the module
}
// Put the message's buffers back into its state at their paths (the widget protocol's buffer_paths).
function withBuffers(state, paths, buffers) {
  (paths || []).forEach((path, k) => {
    let obj = state;
    for (const key of path.slice(0, -1)) obj = obj[key];
    obj[path[path.length - 1]] = fromBase64(buffers[k]);
  });
  return state;
}

// ------------------------------------------------------------------ the widgets

const widgets = new Map();  // comm_id -> {model, cleanup, removeView, canvas}
let currentCanvas = null;

function open(commId, data, buffers) {
  const state = withBuffers(data.state, data.buffer_paths, buffers || []);
  const model = new Model(state, {
    onSend: (content, bufs) => emit({ op: "msg", comm_id: commId, data: { method: "custom", content },
      buffers: (bufs || []).map(toBase64) }),
    onSave: (changed) => emit({ op: "msg", comm_id: commId, data: { method: "update", state: changed, buffer_paths: [] },
      buffers: [] }),
  });
  const cleanup = module.default.initialize ? module.default.initialize({ model }) : null;
  const el = new FakeElement("div");
  const removeView = module.default.render({ model, el });
  const canvas = findCanvas(el);
  widgets.set(commId, { model, cleanup, removeView, canvas });
  currentCanvas = canvas;
}

function message(commId, data, buffers) {
  const w = widgets.get(commId);
  if (!w) return;
  if (data.method === "update") {
    const state = withBuffers(data.state, data.buffer_paths, buffers || []);
    for (const [name, value] of Object.entries(state)) w.model.setFromPython(name, value);
  } else if (data.method === "custom") {
    w.model.custom(data.content, (buffers || []).map(fromBase64));
  }  // echo_update: Python confirming what this side set; nothing to do
}

function close(commId) {
  const w = widgets.get(commId);
  if (!w) return;
  widgets.delete(commId);
  if (w.removeView) w.removeView();
  if (w.cleanup) w.cleanup();
  if (currentCanvas === w.canvas) currentCanvas = null;
}

// The newest open engine's counters (what benchmarks/browser_engine.py reads in a page).
function info() {
  const es = [...(globalThis.__grasswidgetEngines || new Map()).values()].filter((e) => !e.closed);
  const e = es[es.length - 1];
  if (!e) return null;
  return { frames: e.frames, n: e.n, now: performance.now(), visible: e.visible || null,
    occluded: e.occluded === undefined ? null : e.occluded, rastered: e.rastered === undefined ? null : e.rastered,
    counts_switches: e.countsSwitches || null, counts_read_at: e.countsReadAt, counts_pending: e.countsPending,
    adapter: e.adapterText || null, timing: e.timing,
    canvas: currentCanvas ? [currentCanvas.width, currentCanvas.height] : null };
}

// ------------------------------------------------------------------ the loop

let exiting = false;
const lines = createInterface({ input: process.stdin, crlfDelay: Infinity });
lines.on("line", (line) => {
  if (!line.trim()) return;
  const m = JSON.parse(line);
  if (m.op === "open") open(m.comm_id, m.data, m.buffers);
  else if (m.op === "msg") message(m.comm_id, m.data, m.buffers);
  else if (m.op === "close") close(m.comm_id);
  else if (m.op === "info") emit({ op: "info", id: m.id, info: info() });
  else if (m.op === "exit") exiting = true;
  else throw new Error(`unknown op ${m.op}`);
});
lines.on("close", () => { exiting = true; });

const adapter = await gpu.requestAdapter();
emit({ op: "ready", node: process.version, adapter: { vendor: adapter.info.vendor, architecture: adapter.info.architecture,
  device: adapter.info.device, description: adapter.info.description,
  timestamp_query: adapter.features.has("timestamp-query") } });
while (!exiting) await pump(currentCanvas);
for (const commId of [...widgets.keys()]) close(commId);
process.exit(0);
