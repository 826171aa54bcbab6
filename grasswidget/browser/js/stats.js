// @ts-check
// What the engine tells Python about its frames: the stats message (every stats_interval_ms) with
// the counts read back from the GPU and the frame times that feed "auto", and the steps reports.
// Stats {fps, visible (per LOD class), occluded, rastered, step_count, steps, frame_ms, frame_size,
//   adapter, views, frame_times, timed_switches, counts_switches}, decoded in Python by
//   grasswidget.views.browser. frame_times: the ms (start to onSubmittedWorkDone) of the
//   frames since the last message drawn with the switch state timed_switches ([occlusion, compute
//   raster] as executed from u_cull; the list restarts when it changes; the newest
//   frame_rules.engine.frame_times_kept kept); counts_switches: the state of the frame the counts
//   are of. Python's "auto" switches (grasswidget.browser.trial_feed) measure by them.

import { readCounters } from "./rules.js";

/** @typedef {import("../types.js").Report} Report */

/** The engine's frame counts and times, and its reports of them. */
export class EngineStats {
  /** @param {Report} report */
  constructor(report) {
    this.report = report;
    this.frames = 0;              // frames whose GPU work completed
    this.statsFrames = 0;         // this.frames at the last stats message
    this.statsTime = performance.now();
    /** @type {number | null} */
    this.lastFrameMs = null;
    /** @type {number[]} */
    this.frameTimes = [];
    /** @type {boolean[] | null} */
    this.timedSwitches = null;
    /** @type {number[] | null} per LOD class, from the last read-back */
    this.visible = null;
    /** @type {number | null} */
    this.occluded = null;
    /** @type {number | null} */
    this.rastered = null;
    /** @type {boolean[] | null} */
    this.countsSwitches = null;
    this.visibleAt = 0;           // performance.now() of the last read-back
    this.argsReadPending = false;
    this.lastArgsRead = 0;
    /** @type {number[] | null} */
    this.frameSize = null;
    this.pendingSteps = 0;        // steps since the last stats message
    this.rollSteps = 0;           // steps since the last "steps" report
    this.lastRollReport = 0;
  }

  /** Back in sight after a rest: frames/s is measured from now, not over the time at rest. */
  restart() {
    this.statsTime = performance.now();
    this.statsFrames = this.frames;
  }

  /**
   * `n` steps ran; with `reportSteps` Python hears how many (it moves a rolling ball), at most
   * once every `reportMs` milliseconds (Python's frame_rules.input.steps_report_ms).
   * @param {number} n @param {boolean} reportSteps @param {number} reportMs
   */
  stepsRan(n, reportSteps, reportMs) {
    this.pendingSteps += n;
    if (!reportSteps) return;
    this.rollSteps += n;
    const now = performance.now();
    if (!this.lastRollReport || now - this.lastRollReport > reportMs) {
      this.report("steps", "", { steps: this.rollSteps });
      this.rollSteps = 0;
      this.lastRollReport = now;
    }
  }

  /** The size (device pixels) of the first view drawn. @param {number} width @param {number} height */
  drewSize(width, height) { this.frameSize = [width, height]; }

  /** Whether this frame should read the counters back (half a stats interval since the last). @param {number} intervalMs */
  wantsCounts(intervalMs) {
    return !this.argsReadPending && performance.now() - this.lastArgsRead > intervalMs / 2;
  }

  /**
   * A frame's GPU work completed after `ms` with the switch state `switches`; the times restart
   * when the state changes (at most `kept` kept: the newest).
   * @param {boolean[]} switches @param {number} ms @param {number} kept
   */
  frameDone(switches, ms, kept) {
    this.frames += 1;
    this.lastFrameMs = ms;
    const same = this.timedSwitches && this.timedSwitches[0] === switches[0] && this.timedSwitches[1] === switches[1];
    if (!same) { this.timedSwitches = switches; this.frameTimes = []; }
    this.frameTimes.push(ms);
    while (this.frameTimes.length > kept) this.frameTimes.shift();
  }

  /**
   * Read the counters a frame copied into `buffer` (Python's frame_rules.counters layout).
   * @param {GPUBuffer} buffer @param {any} layout frame_rules.counters @param {boolean[]} switches the frame's state
   * @param {boolean} hasOcclusion @param {boolean} hasRaster the pipelines exist
   */
  readCounts(buffer, layout, switches, hasOcclusion, hasRaster) {
    this.argsReadPending = true;
    this.lastArgsRead = performance.now();
    buffer.mapAsync(GPUMapMode.READ).then(() => {
      const counts = readCounters(new Uint32Array(buffer.getMappedRange().slice(0)), layout);
      buffer.unmap();
      // Both occlusion phases' draws; occluded null while occlusion culling is off (as the kernel's stats).
      this.visible = counts.visible_per_class;
      const [occlusionWasOn, rasterWasOn] = switches;
      this.occluded = hasOcclusion && occlusionWasOn ? counts.occluded : null;
      // Blades drawn by the compute rasterizer (both phases); 0 while it is off (as the kernel's stats).
      this.rastered = hasRaster ? (rasterWasOn ? counts.rastered : 0) : null;
      this.countsSwitches = switches;  // the state of the frame counted
      this.visibleAt = performance.now();
      this.argsReadPending = false;
    }, () => { this.argsReadPending = false; });
  }

  /**
   * The stats message, when `intervalMs` passed since the last.
   * @param {number} intervalMs @param {{step_count: number, adapter: string, views: number}} engine
   */
  maybeSend(intervalMs, engine) {
    const now = performance.now();
    if (now - this.statsTime < intervalMs) return;
    const fps = ((this.frames - this.statsFrames) * 1000) / (now - this.statsTime);
    this.statsFrames = this.frames;
    this.statsTime = now;
    const steps = this.pendingSteps;
    this.pendingSteps = 0;
    this.report("stats", "", {
      fps, visible: this.visible, occluded: this.occluded, rastered: this.rastered, step_count: engine.step_count, steps,
      frame_ms: this.lastFrameMs, frame_size: this.frameSize, adapter: engine.adapter, views: engine.views,
      frame_times: this.frameTimes, timed_switches: this.timedSwitches, counts_switches: this.countsSwitches,
    });
    this.frameTimes = [];
  }
}
