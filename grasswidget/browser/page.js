// @ts-check
// grasswidget's live page: runs the browser engine (its one module text, grasswidget.browser.esm, embedded)
// with a local model in place of the kernel, and a plain-HTML control panel.
//
// The data block (written by grasswidget/browser/page.py) holds the engine's
// source, the synced state of a BrowserEngineWidget (binary traits base64), and the
// controls, each described by Python as patches of that state. This script
// knows no trait names: it applies what Python described, answers the engine's
// messages that the kernel would answer (ball, key, stats), and ignores the rest.

/**
 * One control of the panel, as Python described it (grasswidget.browser.page.page_controls).
 * @typedef {object} Control
 * @property {string} id
 * @property {string} kind "play" | "slider" | "select" | "checkbox" | "ball"
 * @property {string} label
 * @property {any[]} values each value the control may take
 * @property {string[]} [labels] the values' words
 * @property {number} value the index it starts at
 * @property {{bin: Object<string, number[][]>}} footprint byte runs [start, end) of each binary trait it touches
 * @property {{bin: Object<string, string>, json: Object<string, any>}[]} patches each value's bytes (base64) and JSON traits
 * @property {{bin: [string, number, number, number, number][], json: [string, (string|number)[], number, number, number][]}} [slots]
 *   the ball: the numbers that follow its (x, z), c + ax x + az z
 * @property {number[]} [reach] the ball: [x_min, x_max, z_min, z_max] its centre may reach (m)
 * @property {number[]} [position] the ball: its (x, z) now (m)
 * @property {boolean} [on] the ball: shown now
 */
/**
 * The page's data block (grasswidget.browser.page.page_html).
 * @typedef {object} PageData
 * @property {string} engine the engine's one module text
 * @property {Object<string, any>} state the synced state (binary traits base64)
 * @property {string[]} binary the names of the binary traits
 * @property {Control[]} controls
 * @property {{json: Object<string, any>}} home the home view's traits
 * @property {{keys: Object<string, string>}} input grasswidget.core.interaction.input_rules
 * @property {string | null} still a PNG, base64
 * @property {number[]} size [width, height] CSS px
 * @property {number} blades
 * @property {string} title
 * @property {string} note
 */
/**
 * What the page shows the tests (window.grasswidgetPage).
 * @typedef {object} PageStatus
 * @property {PageModel} model
 * @property {PageData} data
 * @property {any} stats the engine's last stats message
 * @property {string} status "starting" | "ok" | "unavailable"
 * @property {string[]} errors
 * @property {Object<string, Control>} controls
 * @property {number} [t_engine_loaded] ms (performance.now) when the engine's module loaded
 * @property {(() => void) | void} [dispose] the engine's render() clean-up
 */

/** @type {PageData} */
const data = JSON.parse(/** @type {HTMLElement} */ (document.getElementById("gw-data")).textContent || "{}");
/** The page's element of this id (page.html has each). @param {string} id @returns {HTMLElement} */
const $ = (id) => /** @type {HTMLElement} */ (document.getElementById(id));

/** @param {string} text base64 @returns {Uint8Array} */
function fromB64(text) {
  const bin = atob(text);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

/** @param {ArrayBufferView} view @returns {Uint8Array} */
function bytesOf(view) {
  return new Uint8Array(view.buffer, view.byteOffset, view.byteLength);
}

// ------------------------------------------------------------------ the model shim (anywidget's model API)

class PageModel {
  /** @param {Object<string, any>} state @param {string[]} binary */
  constructor(state, binary) {
    /** @type {Object<string, any>} */
    this.state = {};
    for (const [k, v] of Object.entries(state)) {
      this.state[k] = binary.includes(k) ? new DataView(fromB64(v).buffer) : v;
    }
    /** @type {Map<string, Set<(...args: any[]) => void>>} */
    this.listeners = new Map();
    /** @type {((msg: any, buffers: ArrayBuffer[]) => void) | null} */
    this.onSend = null;
  }
  /** @param {string} name */
  get(name) { return this.state[name]; }
  /** @param {string} name @param {any} value */
  set(name, value) {
    const old = this.state[name];
    this.state[name] = value;
    if (old !== value) this.emit(`change:${name}`, value);
    this.emit("set", name, value);
  }
  /** @param {string} event @param {(...args: any[]) => void} fn */
  on(event, fn) {
    let set = this.listeners.get(event);
    if (!set) this.listeners.set(event, set = new Set());
    set.add(fn);
  }
  /** @param {string} [event] @param {(...args: any[]) => void} [fn] */
  off(event, fn) {
    if (!event) { this.listeners.clear(); return; }
    const set = this.listeners.get(event);
    if (set) { if (fn) set.delete(fn); else set.clear(); }
  }
  /** @param {string} event @param {...any} args */
  emit(event, ...args) {
    for (const fn of [...(this.listeners.get(event) || [])]) {
      try { fn(...args); } catch (err) { console.error(err); }
    }
  }
  // The engine's messages to the kernel.
  /** @param {any} msg @param {any} [_callbacks] @param {ArrayBuffer[]} [buffers] */
  send(msg, _callbacks, buffers) { if (this.onSend) this.onSend(msg, buffers || []); }
  save_changes() {}
  // A message to the engine, as the kernel would send it.
  /** @param {any} msg */
  deliver(msg) { this.emit("msg:custom", msg, []); }
}

const model = new PageModel(data.state, data.binary);

// ------------------------------------------------------------------ applying what Python described

/** @param {Control} control @param {number} index */
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

/** The index of the control's value the state holds now, or -1. @param {Control} control @returns {number} */
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

/** @param {Control} ball @param {number} x @param {number} z (m) */
function placeBall(ball, x, z) {
  const [x0, x1, z0, z1] = /** @type {number[]} */ (ball.reach);  // Python's (grasswidget.core.interaction.ball_reach)
  x = Math.min(Math.max(x, x0), x1);
  z = Math.min(Math.max(z, z0), z1);
  /** @type {Object<string, DataView>} */
  const bins = {};
  /** @type {Object<string, any>} */
  const jsons = {};
  const slots = /** @type {NonNullable<Control["slots"]>} */ (ball.slots);
  for (const [name, offset, c, ax, az] of slots.bin) {
    if (!bins[name]) bins[name] = new DataView(bytesOf(model.get(name)).slice().buffer);
    bins[name].setFloat32(offset, c + ax * x + az * z, true);
  }
  for (const [name, path, c, ax, az] of slots.json) {
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
/** @type {(() => void)[]} */
const refreshers = [];
let applying = false;

/** @param {Control} control @param {number} index */
function choose(control, index) {
  applying = true;
  try {
    applyPatch(control, index);
    if (control.kind === "ball") {
      control.on = control.values[index] === true;
      const [x, z] = /** @type {number[]} */ (control.position);
      if (control.on) placeBall(control, x, z);
    }
  } finally { applying = false; }
  refresh();
}

function refresh() {
  for (const fn of refreshers) fn();
}

/** @param {any} v @returns {string} */
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
      refreshers.push(() => { b.textContent = (c.labels || [])[Math.max(0, currentIndex(c))]; });
      panel.append(b);
      continue;
    }
    const text = document.createElement("span");
    text.textContent = c.label;
    if (c.kind === "slider") {
      const input = document.createElement("input");
      input.type = "range"; input.min = "0"; input.max = String(c.values.length - 1); input.step = "1";
      input.value = String(c.value);
      input.setAttribute("aria-label", c.label);
      const out = document.createElement("output");
      input.addEventListener("input", () => { choose(c, Number(input.value)); });
      refreshers.push(() => {
        const i = currentIndex(c);
        if (i >= 0) input.value = String(i);
        out.textContent = fmt(c.values[Number(input.value)]);
      });
      label.append(text, input, out);
    } else if (c.kind === "select") {
      const sel = document.createElement("select");
      sel.setAttribute("aria-label", c.label);
      c.values.forEach((v, i) => {
        const o = document.createElement("option");
        o.value = String(i); o.textContent = c.labels ? c.labels[i] : String(v); sel.append(o);
      });
      sel.addEventListener("change", () => choose(c, Number(sel.value)));
      refreshers.push(() => { const i = currentIndex(c); if (i >= 0) sel.value = String(i); });
      label.append(text, sel);
    } else {  // checkbox, ball
      const box = document.createElement("input");
      box.type = "checkbox";
      box.addEventListener("change", () => choose(c, c.values.indexOf(box.checked)));
      if (c.kind === "ball") {  // its position moves it off the patch it was switched on with
        c.on = c.values[c.value] === true;
        refreshers.push(() => { box.checked = !!c.on; });
      } else {
        refreshers.push(() => { const i = currentIndex(c); box.checked = i >= 0 && c.values[i] === true; });
      }
      label.append(box, text);
    }
    panel.append(label);
  }
  /** @param {string} text @param {() => void} fn */
  const button = (text, fn) => {
    const b = document.createElement("button");
    b.type = "button"; b.textContent = text; b.addEventListener("click", fn);
    panel.append(b);
  };
  button("Reset view", resetView);
  button("Reset blades", () => model.deliver({ type: "reset" }));
  refresh();
}

// Play or pause, as the panel's play button does.
function togglePlay() {
  const play = data.controls.find((c) => c.kind === "play");
  if (play) choose(play, currentIndex(play) === 0 ? 1 : 0);
}

function resetView() {
  for (const [name, value] of Object.entries(data.home.json)) model.set(name, structuredClone(value));
}

// ------------------------------------------------------------------ the engine's messages

/** @type {PageStatus} */
const page = { model, data, stats: null, status: "starting", errors: [], controls };
/** @type {any} */ (window).grasswidgetPage = page;

/** @param {any} msg the engine's stats message */
function showStats(msg) {
  page.stats = msg;
  const visible = (msg.visible || []).reduce((/** @type {number} */ a, /** @type {number} */ b) => a + b, 0);
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
    case "key": {  // what a key does is Python's (data.input.keys, as grasswidget.core.interaction.key_action)
      const action = msg.modifiers && msg.modifiers.length ? undefined : data.input.keys[String(msg.key).toLowerCase()];
      if (action === "step") model.deliver({ type: "step", n: 1 });
      else if (action === "reset_camera") resetView();
      else if (action === "toggle_play") togglePlay();
      break;
    }
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

/** @param {string} detail why there is no WebGPU */
function fallback(detail) {
  page.status = "unavailable";
  $("gw-view").hidden = true;
  $("gw-panel").hidden = true;
  $("gw-help").hidden = true;
  const still = /** @type {HTMLImageElement} */ ($("gw-still"));
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
  const still = /** @type {HTMLImageElement} */ ($("gw-still"));
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
    try { adapter = await navigator.gpu.requestAdapter(); } catch { adapter = null; }
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
