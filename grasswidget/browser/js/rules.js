// @ts-check
// The rules the browser engine must still compute per frame itself, each the twin of one Python
// function that decides it (a node test, tests/browser/test_engine_rules.py, checks every one
// against its twin on many inputs, as the WGSL twins are checked against NumPy). Every number
// they use comes from Python as data (the frame_rules trait: grasswidget.core.engine_inputs.frame_rules).
//
//   SimClock            grasswidget.views.clock.SimClock (steps owed by the wall clock; slow motion)
//   clampOrbit          grasswidget.core.orbit_limits.clamp_orbit (the orbit limits between two kernel messages)
//   orbitDrag, panDrag, wheelZoom   grasswidget.core.camera_rules.orbit_drag / pan_drag / wheel_zoom
//   cameraWorld, perspective        grasswidget.core.camera_rules.camera_world / perspective (a dragged camera)
//   hzbLayout           grasswidget.core.reference.hzb_layout (the pyramid of a canvas the browser sized)
//   windTime            grasswidget.core.engine_inputs.wind_time (wind time of step k, modulo the period)
//   stepsPerDispatch    grasswidget.core.engine_inputs.steps_per_dispatch
//   workgroups          grasswidget.gpu.wgsl_templates.workgroups (with frame_rules.dispatch's workgroup size)
//   readCounters        grasswidget.core.engine_inputs.read_counters (the stats' counts, frame_rules.counters)
//   PointerGesture      grasswidget.core.interaction.PointerGesture (click or drag; the ctrl gesture)
//   keyAction, displayRatio, domButton   grasswidget.core.interaction.key_action / display_ratio / DOM_BUTTONS

import { add, clamp, cross, norm, scale, sub } from "./linalg.js";

/**
 * @typedef {object} ClockRules grasswidget.core.engine_inputs.clock_rules
 * @property {number} dt the fixed step (s)
 * @property {number} wind_period s; 0: no period
 * @property {number} max_steps_per_frame a frame owed more gets this many, the rest is dropped
 */
/**
 * @typedef {object} DispatchRules grasswidget.core.engine_inputs.dispatch_rules
 * @property {number} workgroup_size threads per workgroup of the per-blade compute shaders
 * @property {number} max_groups_x workgroups along x before a dispatch folds into y
 * @property {number} blade_steps_per_dispatch blade steps (blades x steps) one simulation dispatch may take
 */
/**
 * @typedef {object} DragRules grasswidget.core.camera_rules.drag_rules
 * @property {number} radians_per_pixel
 * @property {number} max_elevation radians
 * @property {number} wheel_per_delta
 * @property {number} wheel_max_log
 * @property {number} sync_ms
 */
/**
 * @typedef {object} InputRules grasswidget.core.interaction.input_rules (frame_rules.input)
 * @property {number} click_slop_px a press released nearer than this (CSS px) to where it was pressed is a click
 * @property {string[]} pick_modifiers modifier names that make a left press the ctrl gesture
 * @property {string} ball_modifier the modifier that makes a left press move the ball
 * @property {{left: number, right: number, middle: number}} buttons the rules' button numbers
 * @property {number[]} dom_buttons the rules' number of each DOM PointerEvent.button
 * @property {number} max_pixel_ratio rendered pixels per CSS pixel, at most, when following the display
 * @property {number} steps_report_ms while a ball rolls, the steps are reported at most this often (ms)
 * @property {number} ball_margin the ball may go this fraction of the field's extent past its edges
 * @property {Object<string, string>} keys each key's action (lower-case DOM key names)
 */
/**
 * @typedef {object} OrbitRules grasswidget.core.orbit_limits.OrbitLimits as a dict (frame_rules.orbit)
 * @property {number[]} lo (x, z) corner of the area the target may move in, m
 * @property {number[]} hi (x, z) corner, m
 * @property {number|null} ground_y the ground's height (m); null: no ground
 * @property {number} top_y the highest the target may go, m
 * @property {number} min_distance m
 * @property {number} max_distance m
 * @property {number} clearance the camera's least height above the ground, m
 * @property {number} max_elevation_deg degrees
 */
/**
 * @typedef {object} Camera the camera trait
 * @property {number[]} position m
 * @property {number[]} target m
 * @property {number} fov_deg vertical
 * @property {number} near m
 * @property {number} far m
 */

/** The clock of playing by the wall clock: wall seconds (times time_scale) spent in whole fixed
 * steps of dt; at most maxSteps a frame, the rest dropped (slow motion). */
export class SimClock {
  /** @param {number} maxSteps the most steps a frame takes (ClockRules.max_steps_per_frame) */
  constructor(maxSteps) {
    this.maxSteps = maxSteps;
    this.running = false;
    /** @type {number|null} */
    this.last = null;
    this.acc = 0;
    this.lastSteps = 0;
    this.capped = false;
  }

  /** @param {number} now wall time (s) */
  start(now) {
    if (!this.running) { this.running = true; this.last = now; }
  }

  stop() {
    this.running = false;
    this.last = null;
    this.acc = 0;
  }

  /** @param {number} now wall time (s) */
  reset(now) {
    this.acc = 0;
    if (this.running) this.last = now;
  }

  /**
   * Steps owed for the wall time since the last call; 0 while stopped.
   * @param {number} now wall time (s) @param {number} dt s @param {number} timeScale >= 0
   * @returns {number}
   */
  frameSteps(now, dt, timeScale) {
    if (!this.running) { this.lastSteps = 0; this.capped = false; return 0; }
    const wall = Math.max(0, now - (this.last ?? now)) * Math.max(0, timeScale);
    this.last = now;
    this.acc += wall;
    let n = Math.floor(this.acc / dt + 1e-9);
    this.capped = n > this.maxSteps;
    if (this.capped) { n = this.maxSteps; this.acc = 0; } else this.acc = Math.max(0, this.acc - n * dt);
    this.lastSteps = n;
    return n;
  }
}

/**
 * (position, target) moved the least way into the limits: target into its box (the camera
 * follows), distance into the zoom range, elevation into its range (keeping the azimuth).
 * @param {number[]} position @param {number[]} target
 * @param {OrbitRules} limits an OrbitLimits as a dict (frame_rules.orbit)
 * @returns {[number[], number[]]} [position, target]
 */
export function clampOrbit(position, target, limits) {
  const L = limits;
  const c = [clamp(target[0], L.lo[0], L.hi[0]), 0, clamp(target[2], L.lo[1], L.hi[1])];
  const floor = L.ground_y === null || L.ground_y === undefined ? -Infinity : L.ground_y;
  c[1] = Math.min(Math.max(target[1], floor), L.top_y);
  const pos = add(position, sub(c, target));
  let off = sub(pos, c);
  let d = Math.hypot(...off);
  if (d < 1e-9) { off = [0, 0, 1]; d = 1e-9; }
  const dNew = clamp(d, L.min_distance, L.max_distance);
  let dir = scale(off, 1 / d);
  const el = Math.asin(clamp(dir[1] / Math.max(Math.hypot(...dir), 1e-12), -1, 1));
  let loEl;
  if (floor === -Infinity) loEl = -(L.max_elevation_deg * Math.PI) / 180;
  else loEl = Math.asin(clamp((floor + L.clearance - c[1]) / Math.max(dNew, 1e-9), -1, 1));
  const hiEl = (L.max_elevation_deg * Math.PI) / 180;
  const elNew = Math.min(Math.max(el, loEl), hiEl);
  if (elNew !== el) {
    let horizontal = [dir[0], 0, dir[2]];
    const h = Math.hypot(...horizontal);
    horizontal = h > 1e-9 ? scale(horizontal, 1 / h) : [0, 0, 1];
    dir = add(scale(horizontal, Math.cos(elNew)), [0, Math.sin(elNew), 0]);
  }
  return [add(c, scale(dir, dNew)), c];
}

/**
 * An orbit drag of (dx, dy) CSS pixels: azimuth less dx, elevation plus dy, held short of the poles.
 * @param {number[]} position @param {number[]} target @param {number} dx @param {number} dy
 * @param {DragRules} drag
 * @returns {number[]} the new position (distance to target kept)
 */
export function orbitDrag(position, target, dx, dy, drag) {
  const off = sub(position, target);
  const r = Math.hypot(...off);
  const az = Math.atan2(off[0], off[2]) - dx * drag.radians_per_pixel;
  let el = Math.asin(clamp(off[1] / r, -1, 1));
  el = clamp(el + dy * drag.radians_per_pixel, -drag.max_elevation, drag.max_elevation);
  return add(target, [r * Math.cos(el) * Math.sin(az), r * Math.sin(el), r * Math.cos(el) * Math.cos(az)]);
}

/**
 * A pan drag of (dx, dy) CSS pixels in a view heightPx CSS pixels high: camera and target move in the view plane.
 * @param {number[]} position @param {number[]} target @param {number} fovDeg
 * @param {number} dx @param {number} dy @param {number} heightPx
 * @returns {[number[], number[]]} [position, target]
 */
export function panDrag(position, target, fovDeg, dx, dy, heightPx) {
  const world = cameraWorld(position, target);
  const dist = Math.hypot(...sub(position, target));
  const k = (2 * dist * Math.tan((fovDeg * Math.PI) / 360)) / heightPx;
  const right = [world[0], world[1], world[2]], up = [world[4], world[5], world[6]];
  const move = add(scale(right, -dx * k), scale(up, dy * k));
  return [add(position, move), add(target, move)];
}

/**
 * A wheel event: the distance to the target times exp(deltaY wheel_per_delta), held to +-wheel_max_log.
 * @param {number[]} position @param {number[]} target @param {number} deltaY @param {DragRules} drag
 * @returns {number[]} the new position
 */
export function wheelZoom(position, target, deltaY, drag) {
  const k = Math.exp(clamp(deltaY * drag.wheel_per_delta, -drag.wheel_max_log, drag.wheel_max_log));
  return add(target, scale(sub(position, target), k));
}

/**
 * Camera to world (columns: right, up, back, position) for a camera at eye looking at target.
 * @param {number[]} eye @param {number[]} target
 * @returns {Float64Array} column-major 4 x 4
 */
export function cameraWorld(eye, target) {
  const back = norm(sub(eye, target));
  let right = cross([0, 1, 0], back);
  if (Math.hypot(...right) < 1e-9) right = [1, 0, 0];
  right = norm(right);
  const up = cross(back, right);
  return new Float64Array([...right, 0, ...up, 0, ...back, 0, ...eye, 1]);
}

/**
 * Perspective projection with a vertical fov, WebGPU depth 0 (near) .. 1 (far).
 * @param {number} fovDeg @param {number} aspect width / height @param {number} near @param {number} far
 * @returns {Float64Array} column-major 4 x 4
 */
export function perspective(fovDeg, aspect, near, far) {
  const f = 1 / Math.tan((fovDeg * Math.PI) / 360);
  const m = new Float64Array(16);
  m[0] = f / aspect;
  m[5] = f;
  m[10] = far / (near - far);
  m[11] = -1;
  m[14] = (near * far) / (near - far);
  return m;
}

/**
 * Where each level of the max-depth pyramid lives in one float32 buffer, [offset, width, height,
 * pitch] in texels, level 0 first. Level 0 is the depth buffer (rows every rowAlign-aligned pitch:
 * Python's HZB_ROW_ALIGN, sent in shaders.occlusion.row_align); level k + 1 halves level k
 * rounding up, down to 1 x 1, rows packed.
 * @param {number} width @param {number} height pixels @param {number} rowAlign
 * @returns {number[][]}
 */
export function hzbLayout(width, height, rowAlign) {
  if (!(width >= 1 && height >= 1)) throw new Error(`hzbLayout needs a viewport of at least 1 x 1 pixels; got ${width} x ${height}`);
  let w = Math.floor(width), h = Math.floor(height);
  const pitch = Math.ceil(w / rowAlign) * rowAlign;
  const levels = [[0, w, h, pitch]];
  let offset = pitch * h;
  while (w > 1 || h > 1) {
    w = Math.ceil(w / 2); h = Math.ceil(h / 2);
    levels.push([offset, w, h, w]);
    offset += w * h;
  }
  return levels;
}

/**
 * The wind time of step k: (k dt) mod wind_period (no period: k dt).
 * @param {number} k @param {ClockRules} clock @returns {number} s
 */
export function windTime(k, clock) {
  const t = k * clock.dt;
  return clock.wind_period > 0 ? t % clock.wind_period : t;
}

/**
 * Fixed steps one simulation dispatch of nBlades blades may take (at least 1).
 * @param {number} nBlades @param {DispatchRules} dispatch @returns {number}
 */
export function stepsPerDispatch(nBlades, dispatch) {
  return Math.max(1, Math.floor(dispatch.blade_steps_per_dispatch / Math.max(nBlades, 1)));
}

/**
 * The workgroups of a dispatch of `items` threads, folded into y past max_groups_x.
 * @param {number} items @param {DispatchRules} dispatch @returns {[number, number]}
 */
export function workgroups(items, dispatch) {
  const groups = Math.max(1, Math.ceil(items / dispatch.workgroup_size));
  const x = Math.min(groups, dispatch.max_groups_x);
  return [x, Math.ceil(groups / x)];
}

/**
 * The stats' counts of one read-back, where Python's layout puts them (frame_rules.counters).
 * @param {Uint32Array} words
 * @param {{visible: number[][], occluded: number, rastered: number}} layout grasswidget.core.engine_inputs.counter_layout
 * @returns {{visible_per_class: number[], occluded: number, rastered: number}}
 */
export function readCounters(words, layout) {
  return {
    visible_per_class: layout.visible.map(([i, j]) => words[i] + words[j]),
    occluded: words[layout.occluded],
    rastered: words[layout.rastered],
  };
}

/**
 * The rules' number of a DOM PointerEvent.button (0 left, 1 middle, 2 right, ...).
 * @param {number} b the DOM button @param {InputRules} rules @returns {number} (0: none the rules name)
 */
export function domButton(b, rules) {
  return rules.dom_buttons[b] ?? 0;
}

/**
 * What a key does: "toggle_play", "step", "reset_camera", or null (not ours: any modifier held, or another key).
 * @param {string} key the DOM key name @param {string[]} modifiers held modifier names
 * @param {InputRules} rules @returns {string|null}
 */
export function keyAction(key, modifiers, rules) {
  if (modifiers.length) return null;
  const action = rules.keys[String(key).toLowerCase()];
  return action === undefined ? null : action;
}

/**
 * Rendered pixels per CSS pixel: asked when positive, else the display's ratio (not positive: 1)
 * held to at most max_pixel_ratio.
 * @param {number} deviceRatio window.devicePixelRatio @param {number} asked the pixel_ratio trait (0: the display's)
 * @param {InputRules} rules @returns {number}
 */
export function displayRatio(deviceRatio, asked, rules) {
  if (asked > 0) return asked;
  return Math.min(deviceRatio > 0 ? deviceRatio : 1, rules.max_pixel_ratio);
}

/** One press of a pointer button, press to release (the twin of PointerGesture in Python:
 * the press's kind, then what each move and the release do; positions in CSS pixels). */
export class PointerGesture {
  /** @param {InputRules} rules */
  constructor(rules) {
    this.rules = rules;
    /** @type {string|null} "pick" | "ball" | "pan" | "orbit", null between presses */
    this.kind = null;
    /** @type {number[]} where the press was */
    this.start = [0, 0];
    this.dragging = false;
  }

  /**
   * A press: returns its kind ("pick": left + Ctrl/Cmd, "ball": left + Shift, "pan": right, else "orbit").
   * @param {number} x @param {number} y @param {number} button the rules' number @param {string[]} modifiers
   * @returns {string}
   */
  down(x, y, button, modifiers) {
    const r = this.rules;
    const left = button === r.buttons.left;
    let kind = "orbit";
    if (left && modifiers.some((m) => r.pick_modifiers.includes(m))) kind = "pick";
    else if (left && modifiers.includes(r.ball_modifier)) kind = "ball";
    else if (button === r.buttons.right) kind = "pan";
    this.kind = kind;
    this.start = [x, y];
    this.dragging = kind !== "pick";
    return kind;
  }

  /** @param {number} x @param {number} y @returns {boolean} */
  far(x, y) {
    return Math.hypot(x - this.start[0], y - this.start[1]) >= this.rules.click_slop_px;
  }

  /**
   * A move with the button held: "wait" (a pick still a click), "pan_start", "pan", the kind, or null.
   * @param {number} x @param {number} y @returns {string|null}
   */
  move(x, y) {
    if (this.kind === null) return null;
    if (this.kind !== "pick") return this.kind;
    if (this.dragging) return "pan";
    if (this.far(x, y)) { this.dragging = true; return "pan_start"; }
    return "wait";
  }

  /**
   * The release: "inspect" (a pick that stayed a click), "pan" or "cancel" (a pick that did
   * not), the kind of any other press, or null.
   * @param {number} x @param {number} y @returns {string|null}
   */
  up(x, y) {
    const kind = this.kind;
    if (kind === null) return null;
    const click = kind === "pick" && !this.dragging && !this.far(x, y);
    const started = this.dragging;
    this.kind = null;
    this.dragging = false;
    if (kind !== "pick") return kind;
    if (click) return "inspect";
    return started ? "pan" : "cancel";
  }
}
