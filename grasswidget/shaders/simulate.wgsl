// Blade simulation: `steps` fixed steps of length dt for every blade, in one
// dispatch. Each step: fade the collision strength (fade_collision), forces and
// state validation (tip_step: paper 5.1-5.2), the sphere collisions with validation
// of the pushed blades (collision_passes), their strength (gain_collision), and the
// finite check (validate_finite).
// Blades are independent, so looping inside the shader is exact and needs no
// barriers. The twin of reference.simulate() / reference.simulate_step().
//
// Last in each step, validate_finite puts a blade whose state went non-finite (a user's
// wind WGSL returning NaN or inf) back at rest; a dispatch that did so for any blade sets
// the word after the blades' collision strengths, s_collision[n_blades], to 1 (where the
// buffer has it): Python reads it with the state or the frame stats and warns once.
//
// Engine-neutral body: the engine declares (before this file) the uniform u_sim
// (fields of grasswidget.gpu.simulation.SIM_UNIFORM), s_blades (array<vec4<f32>>,
// read_write), s_collision (array<f32>, read_write: the per-blade collision
// strength eta, 0..1, persistent across steps, then the reset flag), and s_colliders / s_collider_grid
// (read: the spheres and their grid, see collisions.wgsl and core.collider_grid);
// see grasswidget.core.shader_files.

{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.wind_field.wgsl' $}
{$ include 'grasswidget.collisions.wgsl' $}

// wind_field(p, t) and the user's user_wind(p, t): see wind_field.wgsl;
// collision_passes(v0, v1, v2, up, height) over the spheres near the blade: see collisions.wgsl.

@compute @workgroup_size({{ workgroup_size }})
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.y * nwg.x + wid.x) * {{ workgroup_size }}u + lid;
    if (i >= u_sim.n_blades) { return; }

    var blade = load_blade(i);
    let v0 = blade.v0;
    let up = blade.up;
    let h = blade.height;
    let s = blade.stiffness * u_sim.stiffness_scale;
    var v1 = blade.v1;
    var v2 = blade.v2;
    var eta = s_collision[i];
    var reset = false;

    let t1 = width_direction(up, blade.orientation);
    let f = front_direction(up, t1);
    let g_env = environmental_gravity(v0, u_sim.gravity_mode, u_sim.gravity_dir.xyz, u_sim.gravity_center.xyz, u_sim.gravity);
    let g = g_env + front_gravity(g_env, f, u_sim.front_gravity);

    for (var k = 0; k < u_sim.steps; k = k + 1) {
        let t = u_sim.time0 + f32(k) * u_sim.dt;
        eta = fade_collision(eta, u_sim.collision_fade, u_sim.dt);
        let moved = tip_step(v0, v2, up, h, effective_stiffness(s, eta), g, wind_field(v0, t), u_sim.dt);
        let collided = collision_passes(v0, moved.v1, moved.v2, up, h);
        let settled = validate_finite(v0, collided.v1, collided.v2, up, h, gain_collision(eta, collided.add, u_sim.collision_gain));
        v1 = settled.v1;
        v2 = settled.v2;
        eta = settled.eta;
        reset = reset || settled.reset;
    }

    blade.v1 = v1;
    blade.v2 = v2;
    store_blade_guides(i, blade);
    s_collision[i] = eta;
    if (reset && u_sim.n_blades < arrayLength(&s_collision)) {
        s_collision[u_sim.n_blades] = 1.0;
    }
}
