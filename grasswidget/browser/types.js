// @ts-check
// The browser engine's types, for `tsc --checkJs` only (tests/browser/test_js_types.py): JSDoc
// typedefs, no code. No module imports this file at run time (esm.py assembles the modules engine.js imports: not this one);
// the modules name its types as `import("../types.js").Model`.

/** @typedef {DataView<ArrayBuffer>} Bytes a trait's bytes as anywidget gives them */

/**
 * The synced traits of the widget's model: what grasswidget/browser/engine_widget.py (BrowserEngineWidget,
 * `tag(sync=True)`) sends and the engine reads (bytes arrive as DataView).
 * @typedef {Object} Traits
 * @property {string} engine_key one engine per widget model
 * @property {Bytes} blade_data the rest pose, N records of frame_rules.engine.blade_bytes
 * @property {number} n_blades blades (>= 0)
 * @property {Shaders} shaders WGSL texts, binding maps and the compute passes of a frame
 * @property {Bytes} sim_uniform u_sim packed (engine_inputs.sim_uniform_values)
 * @property {Object<string, number[]>} sim_layout u_sim's fields: name -> [offset, bytes]
 * @property {Bytes} cull_uniform u_cull packed
 * @property {Bytes} material_uniform u_material packed
 * @property {Bytes} sky_ground_uniform sky_ground.wgsl's u_material packed
 * @property {Bytes} ball_uniform u_balls packed
 * @property {number} stdinfo_size bytes of the camera uniform
 * @property {Object<string, number[]>} stdinfo_layout the camera uniform's fields: name -> [offset, bytes]
 * @property {FrameRules} frame_rules every rule of a frame as data (core.engine_inputs.frame_rules)
 * @property {boolean} playing the clock runs
 * @property {number} time_scale simulated seconds per wall second
 * @property {Camera} camera the camera (metres, degrees)
 * @property {Bytes} collider_spheres the spheres (vec4 each)
 * @property {Bytes} collider_grid the spheres' grid (u32 words; word 2: the number of spheres)
 * @property {number[]} collider_buffer_bytes bytes of [s_colliders, s_collider_grid]
 * @property {boolean} show_colliders draw the balls
 * @property {boolean} report_steps send "steps" reports (a rolling ball)
 * @property {number} stats_interval_ms milliseconds between stats messages
 * @property {number} pixel_ratio device pixels per CSS pixel (0: the page's)
 * @property {number} width CSS pixels
 * @property {number} height CSS pixels
 * @property {Bytes} frustum_lines the frozen culling camera's edges (empty: not frozen)
 * @property {Bytes} inspect_uniform u_inspect packed
 * @property {number[]} inspected the inspected blade ids
 * @property {{state: string, detail: string}} gpu_status written by the engine
 */

/**
 * anywidget's model handle, typed by the traits.
 * @typedef {Object} Model
 * @property {<K extends keyof Traits>(name: K) => Traits[K]} get
 * @property {<K extends keyof Traits>(name: K, value: Traits[K]) => void} set
 * @property {() => void} save_changes
 * @property {(msg: object, callbacks?: any, buffers?: ArrayBuffer[]) => void} send
 * @property {(event: string, fn: (...args: any[]) => void) => void} on
 * @property {(event: string, fn: (...args: any[]) => void) => void} off
 */

/** @typedef {{position: number[], target: number[], fov_deg: number, near: number, far: number}} Camera */

/**
 * The browser engine's own numbers (core.engine_inputs.engine_rules).
 * @typedef {Object} EngineRules
 * @property {number} frames_in_flight frames queued on the GPU at most
 * @property {number} device_loss_retries restarts after a lost device
 * @property {number} frame_times_kept frame times a stats message carries at most
 * @property {number} ball_vertices one ball's triangle list (balls.wgsl)
 * @property {number} blade_bytes one blade's record
 * @property {number} inspected_point_bytes one inspected blade's control points
 * @property {number} inspected_force_bytes one inspected blade's forces (vec4 each)
 * @property {string[][]} uniforms [buffer, trait] pairs
 */

/**
 * core.engine_inputs.frame_rules.
 * @typedef {Object} FrameRules
 * @property {{dt: number, max_steps_per_frame: number, wind_period: number}} clock
 * @property {any} dispatch core.engine_inputs.dispatch_rules
 * @property {any} orbit core.engine_inputs.orbit_rules
 * @property {any} drag core.camera_rules.drag_rules
 * @property {import("./js/rules.js").InputRules} input core.interaction.input_rules
 * @property {{words: number, first_at: number, second_at: number, raster_at: number, visible: number[][], occluded: number, rastered: number}} counters
 * @property {any} style core.engine_inputs.scene_style
 * @property {EngineRules} engine
 */

/**
 * One shader as Python renders it (browser_wgsl.py).
 * @typedef {Object} Shader
 * @property {string} code WGSL
 * @property {{binding: number, name: string, kind: GPUBufferBindingType, resource?: string}[]} bindings
 * @property {string} [vertex] @property {string} [fragment] entry points
 * @property {boolean} [culled] the culled blades' draw
 */

/** @typedef {Object<string, any>} Shaders browser_wgsl.BrowserShaders.describe(): shaders and specs by name */

/**
 * A pipeline with its bind group layout, shader and (once bound) bind group.
 * @typedef {Object} Pipe
 * @property {any} pipeline GPUComputePipeline or GPURenderPipeline
 * @property {GPUBindGroupLayout} layout
 * @property {Shader} shader
 * @property {GPUBindGroup} [group]
 */

/**
 * A compute pass of a frame (Python's shaders.compute_passes entry, compiled).
 * @typedef {Pipe & {dispatch: string, name: string, label: string, onlyIf: string | undefined, simNow: boolean,
 *   sized: boolean, indirectOffset: number}} ComputePass
 */

/** @typedef {(kind: string, message: string, extra?: object) => void} Report a message to Python */

export {};
