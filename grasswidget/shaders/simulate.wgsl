// Blade simulation: `steps` fixed steps of length dt for every blade, in one
// dispatch. Each step: fade the collision strength, forces (paper 5.1), state
// validation (paper 5.2), sphere collisions and validation of the pushed blades.
// Blades are independent, so looping inside the shader is exact and needs no
// barriers. The twin of reference.simulate() / reference.simulate_step().
//
// Engine-neutral body: the engine declares (before this file) the uniform u_sim
// (fields of grasswidget.gpu.simulation.SIM_UNIFORM), s_blades (array<vec4<f32>>,
// read_write) and s_collision (array<f32>, read_write: the per-blade collision
// strength eta, 0..1, persistent across steps); see grasswidget.core.shader_files.

{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.wind_field.wgsl' $}

// Collision passes per step (reference.COLLISION_PASSES): push, then validate the pushed blades.
const COLLISION_PASSES: i32 = {{ collision_passes }};

// wind_field(p, t) and the user's user_wind(p, t): see wind_field.wgsl.

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

    let t1 = width_direction(up, blade.orientation);
    let f = front_direction(up, t1);
    let g_env = environmental_gravity(v0, u_sim.gravity_mode, u_sim.gravity_dir.xyz, u_sim.gravity_center.xyz, u_sim.gravity);
    let g = g_env + front_gravity(g_env, f, u_sim.front_gravity);
    let iv2 = v0 + up * h;

    for (var k = 0; k < u_sim.steps; k = k + 1) {
        let t = u_sim.time0 + f32(k) * u_sim.dt;
        eta = fade_collision(eta, u_sim.collision_fade, u_sim.dt);
        let s_eff = s * max(1.0 - eta, {{ recovery_floor }});
        let w = wind_force(wind_field(v0, t), v0, v2, up, h);
        v2 = integrate_tip(v2, iv2, s_eff, g + w, u_sim.dt);
        v2 = validate_ground(v0, v2, up);
        v1 = validate_v1(v0, v2, up, h);
        let guides = validate_length(v0, v1, v2, h);
        v1 = guides.v1;
        v2 = guides.v2;

        if (u_sim.n_colliders > 0) {
            var add = 0.0;
            for (var pass_no = 0; pass_no < COLLISION_PASSES; pass_no = pass_no + 1) {
                var v2c = v2;
                var hit = false;
                for (var c = 0; c < u_sim.n_colliders; c = c + 1) {
                    let col = collide_sphere(v0, v1, v2c, u_sim.colliders[c]);
                    v2c = col.v2;
                    add = add + col.add;
                    hit = hit || col.hit;
                }
                if (hit) {
                    v2c = validate_ground(v0, v2c, up);
                    let again = validate_length(v0, validate_v1(v0, v2c, up, h), v2c, h);
                    v1 = again.v1;
                    v2 = again.v2;
                }
            }
            eta = min(eta + u_sim.collision_gain * add, {{ collision_max }});
        }
    }

    blade.v1 = v1;
    blade.v2 = v2;
    store_blade_guides(i, blade);
    s_collision[i] = eta;
}
