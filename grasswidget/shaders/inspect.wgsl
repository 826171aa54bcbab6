// Blade inspector: for each inspected blade (at most 64, one thread each), what
// moves the tip guide v2 in the next step (the twin of reference.blade_forces:
// gravity, recovery and wind in m/s^2, the collision push in m), written as
// arrows from v2 for a pygfx Line
// (s_segments), the control points v0, v1, v2 for pygfx Points (s_points), and
// the raw vectors (s_forces). Runs in every render, reading the GPU state: no
// readback. Everything is in the field's local space (the Line and Points are
// children of the field). Unused slots and zero forces are NaN: not drawn.
//
// The engine declares (see gpu.inspector.InspectShader) u_stdinfo, u_wobject
// (the inspector's world_transform_inv), u_sim (the simulation's uniforms),
// u_inspect (ids, n_ids), s_blades, s_collision, s_colliders and s_collider_grid
// (read; the last two as in collisions.wgsl), s_segments and
// s_points (array<f32>, 3 per vertex) and s_forces (array<vec4<f32>>).

{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.wind_field.wgsl' $}
{$ include 'grasswidget.collisions.wgsl' $}

// Per blade: 2 polygon segments + N_FORCES arrows of 3 segments, 2 vertices each.
const SEGMENT_VERTICES: u32 = {{ segment_vertices }}u;
const N_FORCES: u32 = {{ n_forces }}u;
// An acceleration of this many m/s^2 is drawn as long as the blade is high.
const ARROW_ACCEL_PER_HEIGHT: f32 = {{ arrow_accel_per_height }};
// The collision arrow is the push (m) this many times longer.
const COLLISION_ARROW_SCALE: f32 = {{ collision_arrow_scale }};

// NaN (not drawn). Through a variable: a constant expression may not be NaN (Tint refuses it).
fn not_drawn() -> vec3<f32> {
    var nan_bits = 0x7fc00000u;
    return vec3<f32>(bitcast<f32>(nan_bits));
}

fn set_vertex(k: u32, p: vec3<f32>) {
    s_segments[3u * k + 0u] = p.x;
    s_segments[3u * k + 1u] = p.y;
    s_segments[3u * k + 2u] = p.z;
}

fn set_point(k: u32, p: vec3<f32>) {
    s_points[3u * k + 0u] = p.x;
    s_points[3u * k + 1u] = p.y;
    s_points[3u * k + 2u] = p.z;
}

// Shaft from `start` along `arrow`, then two head strokes in the plane facing `eye`.
fn put_arrow(k: u32, start: vec3<f32>, arrow: vec3<f32>, eye: vec3<f32>) {
    let len = length(arrow);
    if (len < 1e-7) {
        for (var j = 0u; j < 6u; j = j + 1u) { set_vertex(k + j, not_drawn()); }
        return;
    }
    let tip = start + arrow;
    let dir = arrow / len;
    var side = cross(dir, eye - tip);
    if (length(side) < 1e-9) { side = cross(dir, vec3<f32>(1.0, 0.0, 0.0)); }
    if (length(side) < 1e-9) { side = cross(dir, vec3<f32>(0.0, 0.0, 1.0)); }
    side = normalize(side);
    let head = 0.25 * len;
    set_vertex(k + 0u, start);
    set_vertex(k + 1u, tip);
    set_vertex(k + 2u, tip);
    set_vertex(k + 3u, tip - head * dir + 0.5 * head * side);
    set_vertex(k + 4u, tip);
    set_vertex(k + 5u, tip - head * dir - 0.5 * head * side);
}

@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) slot: u32) {
    let base = slot * SEGMENT_VERTICES;
    if (slot >= u_inspect.n_ids) {
        for (var j = 0u; j < SEGMENT_VERTICES; j = j + 1u) { set_vertex(base + j, not_drawn()); }
        for (var j = 0u; j < 3u; j = j + 1u) { set_point(3u * slot + j, not_drawn()); }
        for (var j = 0u; j < N_FORCES; j = j + 1u) { s_forces[N_FORCES * slot + j] = vec4<f32>(0.0); }
        return;
    }
    let i = u_inspect.ids[slot / 4u][slot % 4u];
    let blade = load_blade(i);
    let v0 = blade.v0;
    let v1 = blade.v1;
    let v2 = blade.v2;
    let up = blade.up;
    let h = blade.height;
    let dt = u_sim.dt;
    // u_sim holds the last dispatch (time0, steps) or "now" (steps = 0): the next step's time.
    let t = u_sim.time0 + f32(u_sim.steps) * dt;

    // The forces of simulate.wgsl's next step (reference.blade_forces).
    let eta = fade_collision(s_collision[i], u_sim.collision_fade, dt);
    let s_eff = effective_stiffness(blade.stiffness * u_sim.stiffness_scale, eta);
    let t1 = width_direction(up, blade.orientation);
    let g_env = environmental_gravity(v0, u_sim.gravity_mode, u_sim.gravity_dir.xyz, u_sim.gravity_center.xyz, u_sim.gravity);
    let gravity = g_env + front_gravity(g_env, front_direction(up, t1), u_sim.front_gravity);
    let recovery = (v0 + up * h - v2) * s_eff;
    let wind_at_root = wind_field(v0, t);
    let wind = wind_force(wind_at_root, v0, v2, up, h);

    // Collision: how far (m) the spheres push v2 in that step, after the forces
    // and the validation (the same tip_step and collision_passes as simulate.wgsl).
    let moved = tip_step(v0, v2, up, h, s_eff, gravity, wind_at_root, dt);
    let collision = collision_passes(v0, moved.v1, moved.v2, up, h).v2 - moved.v2;

    var forces = array<vec3<f32>, {{ n_forces }}>(gravity, recovery, wind, collision);
    let eye = (u_wobject.world_transform_inv * vec4<f32>(u_stdinfo.cam_transform_inv[3].xyz, 1.0)).xyz;
    var scales = array<f32, {{ n_forces }}>(h / ARROW_ACCEL_PER_HEIGHT, h / ARROW_ACCEL_PER_HEIGHT,
                                             h / ARROW_ACCEL_PER_HEIGHT, COLLISION_ARROW_SCALE);
    set_point(3u * slot + 0u, v0);
    set_point(3u * slot + 1u, v1);
    set_point(3u * slot + 2u, v2);
    set_vertex(base + 0u, v0);
    set_vertex(base + 1u, v1);
    set_vertex(base + 2u, v1);
    set_vertex(base + 3u, v2);
    for (var k = 0u; k < N_FORCES; k = k + 1u) {
        s_forces[N_FORCES * slot + k] = vec4<f32>(forces[k], s_collision[i]);  // w: the stored collision eta
        put_arrow(base + 4u + 6u * k, v2, forces[k] * scales[k], eye);
    }
}
