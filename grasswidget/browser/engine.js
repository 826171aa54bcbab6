// grasswidget's browser engine: the project's WGSL simulation, culling and ribbons, run in the
// notebook's browser with WebGPU (an anywidget ES module; shipped inside the wheel, nothing is
// fetched at run time). This file is the entry: anywidget's initialize() and render().
//
// The engine only executes what Python describes (grasswidget/browser/view.py):
//   traits   engine_key (one engine per widget model), blade_data (rest pose, N x 64 bytes),
//            n_blades, shaders (WGSL text + binding maps + the compute passes of a frame, in
//            order), sim_uniform / cull_uniform / material_uniform / sky_ground_uniform /
//            ball_uniform (packed structs, computed in Python: grasswidget.core.engine_inputs),
//            sim_layout / stdinfo_layout (field offsets), frame_rules (every rule of a frame as
//            data, grasswidget.core.engine_inputs.frame_rules: {clock, dispatch, orbit, drag, style}),
//            playing, time_scale, camera ({position, target, fov_deg, near, far}),
//            collider_spheres / collider_grid (the colliders and their grid, bytes;
//            grasswidget.core.collider_grid; the balls are drawn from the spheres),
//            show_colliders, report_steps, stats_interval_ms (how often the stats message goes),
//            width, height, pixel_ratio, frustum_lines (the frozen culling camera's 12 edges,
//            24 x 3 float32; empty: not frozen), inspect_uniform (u_inspect packed) and
//            inspected (the inspected blade ids).
//   messages js/messages.js (requests from Python, answers and reports).
//
// The modules, by role (each a real ES module; grasswidget.browser.esm.engine_module_text
// assembles them into the one module text anywidget, the live page and the HTML export load):
//   js/linalg.js       vector and 4 x 4 matrix math
//   js/rules.js        what the engine must still compute per frame, each rule the twin of one
//                      Python function that decides it (the clock's steps, the orbit clamp and
//                      drags, a dragged camera's matrices, the pyramid of a canvas, wind time,
//                      dispatch sizes), with every number from Python's frame_rules
//   js/pictures.js     exported pictures filtered down (Python's export_filter)
//   js/canvas_view.js  CanvasView: one display of the widget, a canvas and its input
//   js/device.js       EngineDevice: WebGPU start-up, device loss, pipelines, views, camera
//   js/resources.js    EngineResources: buffers, Python's bytes into them, bind groups
//   js/culling.js      EngineCulling: occlusion culling's two phases, the compute rasterizer
//   js/passes.js       EnginePasses: simulation, compute passes and draws, the animation frame
//   js/messages.js     EngineMessages: Python's requests, trait changes, stats and steps reports
//
// A compute pass or an overlay with "only_if" runs while its condition holds ("frozen",
// "inspecting", "compute_raster"); a pass with sim_uniform "now" gets u_sim for the time of the next
// step (no steps) first, as the kernel's inspector does. Fixed steps: step(n) runs exactly n steps
// of dt; playing follows the wall clock with the rules of grasswidget.notebook.clock.SimClock.
// Views at rest: a view that is not visible (scrolled away, a collapsed output, a hidden tab: an
// IntersectionObserver per canvas and document.visibilityState) draws nothing; with no view visible
// the engine simulates nothing, sends no stats and asks for no animation frame, and its clock stops
// as pause() stops it (SimClock.stop, Python's rule): on return simulated time goes on from where it
// stopped. canvas.grasswidgetFramesDrawn counts a view's frames (tests).
//
// One engine per widget model (GPU device, buffers, simulation, clock), however many times the
// widget is displayed: anywidget's initialize() makes it, each render() only adds a view (a
// canvas) of it, and every visible view draws the same meadow from the same camera.

import { CanvasView } from "./js/canvas_view.js";
import { EngineMessages } from "./js/messages.js";

export { SimClock, clampOrbit, hzbLayout } from "./js/rules.js";
export { downsample } from "./js/pictures.js";

/** The engine of one widget model: its device, resources, passes and messages (js/*.js). */
class GrassEngine extends EngineMessages {}

// engine_key -> GrassEngine, for the whole page (the module is loaded once per page).
const ENGINES = (globalThis.__grasswidgetEngines = globalThis.__grasswidgetEngines || new Map());

/** @param {object} model @returns {GrassEngine} the model's one engine */
function engineFor(model) {
  const key = model.get("engine_key");
  let engine = ENGINES.get(key);
  if (!engine || engine.closed) {
    engine = new GrassEngine(model);
    ENGINES.set(key, engine);
  }
  return engine;
}

export default {
  // Once per widget model: its one engine (the GPU starts when a view first shows it).
  initialize({ model }) {
    const engine = engineFor(model);
    return () => {
      engine.close();
      if (ENGINES.get(model.get("engine_key")) === engine) ENGINES.delete(model.get("engine_key"));
    };
  },
  // Once per display of the widget: one more view of the same engine.
  render({ model, el }) {
    const engine = engineFor(model);
    const view = new CanvasView(engine, model, el);
    engine.addView(view);
    return () => engine.removeView(view);
  },
};
