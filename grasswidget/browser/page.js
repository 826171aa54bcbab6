// grasswidget's live page: runs the browser engine (its one module text, grasswidget.browser.esm, embedded)
// with a local model in place of the kernel, and a plain-HTML control panel.
//
// The data block (written by grasswidget/browser/page.py) holds the engine's
// source, the synced state of a BrowserEngineWidget (binary traits base64), and the
// controls, each described by Python as patches of that state. This script
// knows no trait names: it applies what Python described, answers the engine's
// messages that the kernel would answer (ball, key, stats), and ignores the rest.

const data = JSON.parse(document.getElementById("gw-data").textContent);
const $ = (id) => document.getElementById(id);

function fromB64(text) {
  const bin = atob(text);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

function bytesOf(view) {
  return new Uint8Array(view.buffer, view.byteOffset, view.byteLength);
}

// ------------------------------------------------------------------ the model shim (anywidget's model API)

class PageModel {
  constructor(state, binary) {
    this.state = {};
    for (const [k, v] of Object.entries(state)) {
      this.state[k] = binary.includes(k) ? new DataView(fromB64(v).buffer) : v;
    }
    this.listeners = new Map();
    this.onSend = null;
  }
  get(name) { return this.state[name]; }
  set(name, value) {
    const old = this.state[name];
    this.state[name] = value;
    if (old !== value) this.emit(`change:${name}`, value);
    this.emit("set", name, value);
  }
  on(event, fn) {
    if (!this.listeners.has(event)) this.listeners.set(event, new Set());
    this.listeners.get(event).add(fn);
  }
  off(event, fn) {
    if (!event) { this.listeners.clear(); return; }
    const set = this.listeners.get(event);
    if (set) { if (fn) set.delete(fn); else set.clear(); }
  }
  emit(event, ...args) {
    for (const fn of [...(this.listeners.get(event) || [])]) {
      try { fn(...args); } catch (err) { console.error(err); }
    }
  }
  // The engine's messages to the kernel.
  send(msg, _callbacks, buffers) { if (this.onSend) this.onSend(msg, buffers || []); }
  save_changes() {}
  // A message to the engine, as the kernel would send it.
  deliver(msg) { this.emit("msg:custom", msg, []); }
}

const model = new PageModel(data.state, data.binary);

// ------------------------------------------------------------------ applying what Python described

function applyPatch(control, index) {
  const patch = control.patches[index];
  for (const [name, runs] of Object.entries(control.footprint.bin)) {
    const bytes = bytesOf(model.get(name)).slice();
    const src = fromB64(patch.bin[name]);
    let o = 0;
    for (const [a, e] of runs) { bytes.set(src.subarray(o, o + e - a), a); o += e - a; }
    model.set(name, new DataView(bytes.buffer));
  }
  for (const [name, value] of Object.entries(patch.json)) model.set(name, structuredClone(value));
}

function currentIndex(control) {
  outer: for (let i = 0; i < control.patches.length; i++) {
    const patch = control.patches[i];
    for (const [name, runs] of Object.entries(control.footprint.bin)) {
      const bytes = bytesOf(model.get(name));
      const src = fromB64(patch.bin[name]);
      let o = 0;
      for (const [a, e] of runs) {
        for (let j = a; j < e; j++) if (bytes[j] !== src[o + j - a]) continue outer;
        o += e - a;
      }
    }
    for (const [name, value] of Object.entries(patch.json)) {
      if (JSON.stringify(model.get(name)) !== JSON.stringify(value)) continue outer;
    }
    return i;
  }
  return -1;
}

function placeBall(ball, x, z) {
  const [x0, x1, z0, z1] = ball.bounds;
  const mx = 0.1 * (x1 - x0), mz = 0.1 * (z1 - z0);
  x = Math.min(Math.max(x, x0 - mx), x1 + mx);
  z = Math.min(Math.max(z, z0 - mz), z1 + mz);
  const bins = {}, jsons = {};
  for (const [name, offset, c, ax, az] of ball.slots.bin) {
    if (!bins[name]) bins[name] = new DataView(bytesOf(model.get(name)).slice().buffer);
    bins[name].setFloat32(offset, c + ax * x + az * z, true);
  }
  for (const [name, path, c, ax, az] of ball.slots.json) {
    if (!jsons[name]) jsons[name] = structuredClone(model.get(name));
    let node = jsons[name];
    for (const key of path.slice(0, -1)) node = node[key];
    node[path[path.length - 1]] = c + ax * x + az * z;
  }
  for (const [name, v] of Object.entries(bins)) model.set(name, v);
  for (const [name, v] of Object.entries(jsons)) model.set(name, v);
  ball.position = [x, z];
}

// ------------------------------------------------------------------ the panel

const controls = Object.fromEntries(data.controls.map((c) => [c.id, c]));
const refreshers = [];
let applying = false;

function choose(control, index) {
  applying = true;
  try {
    applyPatch(control, index);
    if (control.kind === "ball") {
      control.on = control.values[index] === true;
      if (control.on) placeBall(control, ...control.position);
    }
  } finally { applying = false; }
  refresh();
}

function refresh() {
  for (const fn of refreshers) fn();
}

function fmt(v) {
  return typeof v === "number" ? String(Math.round(v * 100) / 100) : String(v);
}

function buildPanel() {
  const panel = $("gw-panel");
  for (const c of data.controls) {
    const label = document.createElement("label");
    label.dataset.control = c.id;
    if (c.kind === "play") {
      const b = document.createElement("button");
      b.type = "button";
      b.className = "gw-play";
      b.addEventListener("click", () => choose(c, currentIndex(c) === 0 ? 1 : 0));
      refreshers.push(() => { b.textContent = c.labels[Math.max(0, currentIndex(c))]; });
      panel.append(b);
      continue;
    }
    const text = document.createElement("span");
    text.textContent = c.label;
    if (c.kind === "slider") {
      const input = document.createElement("input");
      input.type = "range"; input.min = 0; input.max = c.values.length - 1; input.step = 1; input.value = c.value;
      input.setAttribute("aria-label", c.label);
      const out = document.createElement("output");
      input.addEventListener("input", () => { choose(c, Number(input.value)); });
      refreshers.push(() => {
        const i = currentIndex(c);
        if (i >= 0) input.value = i;
        out.textContent = fmt(c.values[Number(input.value)]);
      });
      label.append(text, input, out);
    } else if (c.kind === "select") {
      const sel = document.createElement("select");
      sel.setAttribute("aria-label", c.label);
      c.values.forEach((v, i) => { const o = document.createElement("option"); o.value = i; o.textContent = c.labels ? c.labels[i] : v; sel.append(o); });
      sel.addEventListener("change", () => choose(c, Number(sel.value)));
      refreshers.push(() => { const i = currentIndex(c); if (i >= 0) sel.value = i; });
      label.append(text, sel);
    } else {  // checkbox, ball
      const box = document.createElement("input");
      box.type = "checkbox";
      box.addEventListener("change", () => choose(c, c.values.indexOf(box.checked)));
      if (c.kind === "ball") {  // its position moves it off the patch it was switched on with
        c.on = c.values[c.value] === true;
        refreshers.push(() => { box.checked = c.on; });
      } else {
        refreshers.push(() => { const i = currentIndex(c); box.checked = i >= 0 && c.values[i] === true; });
      }
      label.append(box, text);
    }
    panel.append(label);
  }
  const button = (text, fn) => {
    const b = document.createElement("button");
    b.type = "button"; b.textContent = text; b.addEventListener("click", fn);
    panel.append(b);
  };
  button("Reset view", resetView);
  button("Reset blades", () => model.deliver({ type: "reset" }));
  refresh();
}

function resetView() {
  for (const [name, value] of Object.entries(data.home.json)) model.set(name, structuredClone(value));
}

// ------------------------------------------------------------------ the engine's messages

const page = (window.grasswidgetPage = { model, data, stats: null, status: "starting", errors: [], controls });

function showStats(msg) {
  page.stats = msg;
  const visible = (msg.visible || []).reduce((a, b) => a + b, 0);
  const parts = [];
  if (msg.fps !== null && msg.fps !== undefined) parts.push(`${msg.fps.toFixed(1)} frames/s`);
  if (msg.visible) parts.push(`${visible.toLocaleString("en")} of ${data.blades.toLocaleString("en")} blades drawn`);
  parts.push(`${msg.step_count} steps`);
  if (msg.adapter) parts.push(msg.adapter);
  $("gw-stats").textContent = parts.join(" · ");
}

model.onSend = (msg) => {
  switch (msg.type) {
    case "stats": showStats(msg); break;
    case "ball": {
      const ball = controls.ball;
      if (!ball) break;
      if (!ball.on) choose(ball, 1);
      if (msg.x === null || msg.z === null) break;  // a press on the sky: on, where it was (as the kernel does)
      applying = true;
      try { placeBall(ball, msg.x, msg.z); } finally { applying = false; }
      break;
    }
    case "key":
      if (msg.key === "s") model.deliver({ type: "step", n: 1 });
      else if (msg.key === "r") resetView();
      break;
    case "error": case "device_lost":
      page.errors.push(msg.message);
      $("gw-stats").textContent = msg.message;
      break;
    default: break;  // answers to kernel requests: no kernel here
  }
};

// The engine reports its WebGPU status as {state: "ok" | "unavailable", detail}.
model.on("set", (_name, value) => {
  if (value && typeof value === "object" && !ArrayBuffer.isView(value) && "state" in value && "detail" in value) {
    if (value.state === "ok" && page.status !== "ok") {
      page.status = "ok";
      $("gw-still").hidden = true;
      $("gw-panel").hidden = false;
      $("gw-help").hidden = false;
    } else if (value.state === "unavailable") {
      fallback(value.detail);
    }
  }
  if (!applying) refresh();
});

function fallback(detail) {
  page.status = "unavailable";
  $("gw-view").hidden = true;
  $("gw-panel").hidden = true;
  $("gw-help").hidden = true;
  const still = $("gw-still");
  still.hidden = !data.still;
  still.style.position = "static";
  const note = $("gw-webgpu-note");
  note.textContent = "This live meadow needs WebGPU, which this browser does not offer" +
    (detail ? ` (${detail})` : "") + (data.still ? "; above is a still picture of the same view." : ".");
  note.hidden = false;
}

async function main() {
  document.title = data.title;
  const [w, h] = data.size;
  const still = $("gw-still");
  if (data.still) {
    still.src = `data:image/png;base64,${data.still}`;
    still.width = w; still.height = h;
    still.style.cssText = "position:absolute;left:0;top:0;z-index:1;";
    still.hidden = false;
  }
  $("gw-stage").style.minHeight = `${h}px`;
  $("gw-stage").style.width = `${w}px`;
  $("gw-panel").style.width = `${w}px`;
  buildPanel();
  let adapter = null;
  if (navigator.gpu) {
    try { adapter = await navigator.gpu.requestAdapter(); } catch (err) { adapter = null; }
  }
  if (!adapter) {
    fallback(navigator.gpu ? "requestAdapter() found no adapter" : "navigator.gpu is missing");
    return;
  }
  adapter = null;
  const url = URL.createObjectURL(new Blob([data.engine], { type: "text/javascript" }));
  let engine;
  try {
    engine = (await import(url)).default;
  } finally {
    URL.revokeObjectURL(url);
  }
  page.t_engine_loaded = performance.now();
  page.dispose = engine.render({ model, el: $("gw-view") });
}

main().catch((err) => { console.error(err); fallback(`the page failed to start: ${err.message || err}`); });
