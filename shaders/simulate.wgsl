// Blade simulation: `steps` fixed steps of length dt for every blade, in one
// dispatch. Forces (paper 5.1) then state validation (paper 5.2) each step.
// Blades are independent, so looping inside the shader is exact and needs no
// barriers. The twin of reference.simulate().

{{ bindings_code }}
{$ include 'grasswidget.blade_math.wgsl' $}

@group(0) @binding(1) var<storage, read_write> s_blades: array<vec4<f32>>;

fn wind_field(p: vec3<f32>, t: f32) -> vec3<f32> {
    // Only the travelling wave for now (wind_field id 0).
    return wind_wave(p, t, u_sim.wind_strength, u_sim.wind_dir.xy, u_sim.wind_speed, u_sim.wind_wavelength);
}

@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.y * nwg.x + wid.x) * 256u + lid;
    if (i >= u_sim.n_blades) { return; }

    let p0 = s_blades[4u * i + 0u];
    let p1 = s_blades[4u * i + 1u];
    let p2 = s_blades[4u * i + 2u];
    let p3 = s_blades[4u * i + 3u];
    let v0 = p0.xyz;
    let up = p3.xyz;
    let h = p1.w;
    let s = p3.w * u_sim.stiffness_scale;
    var v1 = p1.xyz;
    var v2 = p2.xyz;

    let t1 = width_direction(up, p0.w);
    let f = front_direction(up, t1);
    let g_env = environmental_gravity(u_sim.gravity_dir.xyz, u_sim.gravity);
    let g = g_env + front_gravity(g_env, f, u_sim.front_gravity);
    let iv2 = v0 + up * h;

    for (var k = 0; k < u_sim.steps; k = k + 1) {
        let t = u_sim.time0 + f32(k) * u_sim.dt;
        let w = wind_force(wind_field(v0, t), v0, v2, up, h);
        v2 = integrate_tip(v2, iv2, s, g + w, u_sim.dt);
        v2 = validate_ground(v0, v2, up);
        v1 = validate_v1(v0, v2, up, h);
        let guides = validate_length(v0, v1, v2, h);
        v1 = guides.v1;
        v2 = guides.v2;
    }

    s_blades[4u * i + 1u] = vec4<f32>(v1, h);
    s_blades[4u * i + 2u] = vec4<f32>(v2, p2.w);
}
