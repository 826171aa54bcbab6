// The passes of a frame: the simulation's fixed steps, Python's compute passes (culling, LOD
// binning, draw order), the ribbon, sky-and-ground, ball and overlay draws; the animation frame
// that runs the clock's steps once and draws every visible view; the counters read back for stats.

import { EngineCulling } from "./culling.js";
import { invert4 } from "./linalg.js";
import { cameraWorld, perspective, readCounters, stepsPerDispatch, windTime } from "./rules.js";

/** At most this many frames are queued on the GPU; a later animation frame draws nothing. */
const MAX_FRAMES_IN_FLIGHT = 2;

/** Simulation, culling and drawing (the resources: EngineResources; occlusion: EngineCulling). */
export class EnginePasses extends EngineCulling {
  // ---------------------------------------------------------------- simulation

  // Exactly n fixed steps of dt, like GrassField.step (wind time (k dt) mod period).
  // Python's u_sim bytes with this dispatch's time0 (s) and steps.
  simUniformBytes(time0, steps) {
    const layout = this.model.get("sim_layout");
    const base = this.model.get("sim_uniform");
    const bytes = new Uint8Array(base.byteLength);
    bytes.set(new Uint8Array(base.buffer, base.byteOffset, base.byteLength));
    const view = new DataView(bytes.buffer);
    view.setFloat32(layout.time0[0], time0, true);
    view.setInt32(layout.steps[0], steps, true);
    return bytes;
  }

  // The wind time of step k: (k dt) mod wind_period (rules.js windTime, Python's engine_inputs.wind_time).
  windTime(k) { return windTime(k, this.rules().clock); }

  // u_sim for "now": the current parameters at the time of the next step, no steps
  // (what the kernel's inspector writes before its pass: gpu.inspector.refresh_uniforms).
  writeSimNow() {
    this.device.queue.writeBuffer(this.res.u_sim, 0, this.simUniformBytes(this.windTime(this.stepCount), 0));
  }

  simulate(n) {
    if (n <= 0) return;
    const device = this.device;
    const perDispatch = stepsPerDispatch(this.n, this.rules().dispatch);
    const [gx, gy] = this.workgroups(this.n);
    let done = 0;
    while (done < n) {
      const chunk = Math.min(perDispatch, n - done);
      device.queue.writeBuffer(this.res.u_sim, 0, this.simUniformBytes(this.windTime(this.stepCount), chunk));
      const encoder = device.createCommandEncoder();
      const pass = encoder.beginComputePass();
      pass.setPipeline(this.sim.pipeline);
      pass.setBindGroup(0, this.sim.group);
      pass.dispatchWorkgroups(gx, gy);
      pass.end();
      device.queue.submit([encoder.finish()]);
      this.stepCount += chunk;
      done += chunk;
    }
  }

  // ---------------------------------------------------------------- drawing

  // The camera's matrices (rules.js, Python's core.camera_rules): camera to world, world to
  // camera, the projection; for this frame's camera, which a drag may have moved since Python's.
  matrices(aspect) {
    const cam = this.camera();
    const world = cameraWorld(cam.position, cam.target);
    const view = invert4(world);
    const proj = perspective(cam.fov_deg, aspect, cam.near, cam.far);
    return { world, view, proj };
  }

  // The camera uniform (pygfx's StdInfo) at the offsets Python's layout gives.
  writeStdInfo(width, height) {
    const { world, view, proj } = this.matrices(width / height);
    const at = this.model.get("stdinfo_layout");
    const f = new Float32Array(this.model.get("stdinfo_size") / 4);
    const put = (name, values) => f.set(values, at[name][0] / 4);
    put("cam_transform", view); put("cam_transform_inv", world);
    put("projection_transform", proj); put("projection_transform_inv", invert4(proj));
    put("physical_size", [width, height]); put("logical_size", [width, height]);
    put("ndc_offset", [1, 1, 0, 0]);
    this.device.queue.writeBuffer(this.res.u_stdinfo, 0, f);
  }

  // Encode one frame of the current state into a colour view of (width, height): Python's
  // compute passes (culling) for this view's camera, then the draws. Submit before the next call
  // (the camera uniform is written now, for this encoder).
  encodeFrame(encoder, colorView, depthTexture, width, height) {
    this.writeStdInfo(width, height);
    const twoPhases = this.occlusionOn();
    const raster = this.rasterOn() ? this.rasterTarget(width, height) : null;
    const depthView = depthTexture.createView();
    const blades = this.workgroups(this.n);
    const cpass = encoder.beginComputePass();
    for (const p of this.computePasses) {
      if (!this.active(p.onlyIf)) continue;
      if (p.simNow) this.writeSimNow();
      cpass.setPipeline(p.pipeline);
      cpass.setBindGroup(0, p.sized ? raster.groups.get(p.name) : p.group);
      if (p.dispatch === "blades") cpass.dispatchWorkgroups(blades[0], blades[1]);
      else if (p.dispatch === "raster_listed") cpass.dispatchWorkgroupsIndirect(this.res.s_raster_dispatch, p.indirectOffset);
      else cpass.dispatchWorkgroups(1);
    }
    cpass.end();
    const pass = encoder.beginRenderPass({
      colorAttachments: [{ view: colorView, loadOp: "clear", storeOp: "store", clearValue: { r: 0, g: 0, b: 0, a: 1 } }],
      depthStencilAttachment: { view: depthView, depthLoadOp: "clear", depthClearValue: 1,
        depthStoreOp: twoPhases ? "store" : "discard" },
    });
    this.ribbonPipes().forEach((p, k) => {
      if (p.shader.culled && twoPhases) return;  // the culled blades are listed by the second phase
      pass.setPipeline(p.pipeline);
      pass.setBindGroup(0, p.group);
      if (p.shader.culled) pass.drawIndirect(this.res.s_culled_args, 0);  // color_by "cull": the culled blades
      else pass.drawIndirect(this.res.s_args, 16 * k);
    });
    if (raster) this.encodeRasterResolve(pass, raster);
    pass.setPipeline(this.skyGround.pipeline);
    pass.setBindGroup(0, this.skyGround.group);
    pass.draw(4);
    if (twoPhases) {
      pass.end();
      this.encodeOcclusionSecondPhase(encoder, depthTexture, width, height, raster);
      const second = this.beginOcclusionDrawPass(encoder, colorView, depthView);
      if (raster) this.encodeRasterResolve(second, raster);
      this.encodeBalls(second);
      return;
    }
    this.encodeBalls(pass);
  }

  // The translucent collider balls (after every blade), then the pass ends.
  encodeBalls(pass) {
    const balls = this.nBalls || 0;
    if (balls > 0 && this.model.get("show_colliders")) {
      pass.setPipeline(this.balls.pipeline);
      pass.setBindGroup(0, this.balls.group);
      pass.draw(6 * 16 * 32, balls);
    }
    for (const o of this.overlays) {
      if (!this.active(o.onlyIf)) continue;
      pass.setPipeline(o.pipeline);
      pass.setBindGroup(0, o.group);
      pass.draw(6, o.instances);
    }
    pass.end();
  }

  depthFor(width, height) {
    // COPY_SRC: occlusion culling copies the depth into its pyramid.
    return this.device.createTexture({ size: [width, height], format: this.depthFormat,
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
  }

  scheduleFrame() {
    if (this.closed || this.raf || !this.visibleViews().length) return;
    this.raf = requestAnimationFrame((t) => { this.raf = null; this.frame(t); });
  }

  // One animation frame: the clock's steps (once, whatever the number of views), then every visible
  // view drawn. With no view visible nothing runs and no new frame is asked for: the engine rests
  // until visibilityChanged() finds a view in sight again.
  frame(now) {
    if (!this.ready || this.closed) return;
    if (this.rebuilding) return;  // rebuildPipelines asks for the next frame when done
    const shown = this.visibleViews();
    if (!shown.length) { this.rest(); return; }
    if (this.resting) {
      // Back in sight: frames/s is measured from now, not over the time at rest.
      this.resting = false;
      this.statsTime = performance.now();
      this.statsFrames = this.frames;
    }
    this.scheduleFrame();
    if (this.inFlight >= MAX_FRAMES_IN_FLIGHT) return;
    const t0 = performance.now();
    try {
      const rules = this.rules().clock;
      this.clock.maxSteps = rules.max_steps_per_frame;
      if (this.model.get("playing")) {
        this.clock.start(now / 1000);
        const n = this.clock.frameSteps(now / 1000, rules.dt, this.model.get("time_scale"));
        if (n > 0) { this.onSteps(n); this.simulate(n); }
      } else {
        this.clock.stop();
      }
      const device = this.device;
      // The switch state this frame executes ([occlusion, compute raster], Python's u_cull words):
      // its time and counts are reported with it (grasswidget.browser.trial_feed measures by them).
      const switches = [this.occlusionOn(), this.rasterOn()];
      let first = true;
      for (const view of shown) {
        if (!view.context) continue;
        const { color, depth, w, h } = view.targets();
        const encoder = device.createCommandEncoder();
        this.encodeFrame(encoder, color, depth, w, h);
        const readArgs = first && !this.argsReadPending && performance.now() - (this.lastArgsRead || 0) > this.statsInterval() / 2;
        if (readArgs) this.encodeArgsRead(encoder);
        device.queue.submit([encoder.finish()]);
        if (readArgs) this.readArgs(switches);
        if (first) this.frameSize = [w, h];
        first = false;
        view.countFrame();
      }
      this.inFlight += 1;
      device.queue.onSubmittedWorkDone().then(() => {
        this.inFlight -= 1;
        this.frames += 1;
        if (!this.timing.first_frame) this.timing.first_frame = performance.now();
        this.lastFrameMs = performance.now() - t0;
        this.timeFrame(switches, this.lastFrameMs);
      }, () => { this.inFlight = 0; });
    } catch (err) {
      this.report("error", `browser frame failed: ${err.message || err}`);
    }
    this.maybeSendStats();
  }

  // The frame times (ms) since the last stats message of frames drawn with the state `switches`;
  // the list restarts when the state changes (at most 32 kept: the newest).
  timeFrame(switches, ms) {
    const same = this.timedSwitches && this.timedSwitches[0] === switches[0] && this.timedSwitches[1] === switches[1];
    if (!same) { this.timedSwitches = switches; this.frameTimes = []; }
    this.frameTimes.push(ms);
    if (this.frameTimes.length > 32) this.frameTimes.shift();
  }

  readArgs(switches) {
    const buf = this.argsRead;
    this.argsReadPending = true;
    this.lastArgsRead = performance.now();
    buf.mapAsync(GPUMapMode.READ).then(() => {
      const counts = readCounters(new Uint32Array(buf.getMappedRange().slice(0)), this.rules().counters);
      buf.unmap();
      // Both occlusion phases' draws; occluded null while occlusion culling is off (as the kernel's stats).
      this.visible = counts.visible_per_class;
      const [occlusionWasOn, rasterWasOn] = switches || [this.occlusionOn(), this.rasterOn()];
      this.occluded = this.occlusion && occlusionWasOn ? counts.occluded : null;
      // Blades drawn by the compute rasterizer (both phases); 0 while it is off (as the kernel's stats).
      this.rastered = this.raster ? (rasterWasOn ? counts.rastered : 0) : null;
      this.countsSwitches = switches || null;  // the state of the frame counted
      this.visibleAt = performance.now();
      this.argsReadPending = false;
    }, () => { this.argsReadPending = false; });
  }
}
