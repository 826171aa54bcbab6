// @ts-check
// The engine's camera: Python's camera trait, held to Python's orbit limits when a view moves it,
// synced back at most every frame_rules.drag.sync_ms; its matrices for a frame (rules.js).

import { invert4 } from "./linalg.js";
import { cameraWorld, clampOrbit, perspective } from "./rules.js";

/** @typedef {import("../types.js").Model} Model */
/** @typedef {import("../types.js").Camera} Camera */

/** The camera rig of one engine: the camera every view draws from, held to the limits, and its matrices. */
export class CameraRig {
  /** @param {Model} model */
  constructor(model) {
    this.model = model;
    /** @type {number | null} performance.now() ms of the last sync to Python */
    this.lastSync = null;
  }

  /** @returns {Camera} the camera now (a drag may have moved it since Python's) */
  get() { return this.model.get("camera"); }

  /**
   * Set the camera (held to the orbit limits from Python); sync to Python at most every
   * frame_rules.drag.sync_ms unless `sync`.
   * @param {Camera} cam @param {boolean} sync
   */
  set(cam, sync) {
    const rules = this.model.get("frame_rules");
    const [position, target] = clampOrbit(cam.position, cam.target, rules.orbit);
    this.model.set("camera", { ...cam, position, target });
    const now = performance.now();
    if (sync || this.lastSync === null || now - this.lastSync > rules.drag.sync_ms) {
      this.model.save_changes();
      this.lastSync = now;
    }
  }

  /**
   * The camera's matrices (rules.js, Python's core.camera_rules): camera to world, world to
   * camera, the projection, for a view of this aspect (width / height).
   * @param {number} aspect
   */
  matrices(aspect) {
    const cam = this.get();
    const world = cameraWorld(cam.position, cam.target);
    const view = invert4(world);
    const proj = perspective(cam.fov_deg, aspect, cam.near, cam.far);
    return { world, view, proj };
  }
}
