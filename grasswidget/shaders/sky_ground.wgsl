// Sky and ground in one full-screen pass (SkyGround, grasswidget/gpu/sky_ground.py).
// Drawn after the opaque objects at the far depth with the "<" depth test, so only
// the pixels nothing else covered are shaded. Per pixel: the view ray meets the
// ground plane y = ground.y inside the square of half-size ground.w around
// ground.xz, nearer than the far plane -> the ground: soil under the field (the
// rectangle `field`, darker the more the grass covers it), the ground beyond it
// (flat colours: a noise here cost a third of a lavapipe frame), fading towards the horizon colour near
// the far plane and with distance fog; else the sky, from the horizon colour up
// to the zenith colour by the ray's elevation (functions: blade_math.wgsl, looks). With
// GrassParams.shadows the ground is lit past the balls and the grass (shadows.wgsl).

{$ include 'pygfx.std.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.shadows.wgsl' $}

struct VertexInput {
    @builtin(vertex_index) index : u32,
};

@vertex
fn vs_main(in: VertexInput) -> Varyings {
    var positions = array<vec2<f32>, 4>(
        vec2<f32>(-1.0, -1.0),
        vec2<f32>( 1.0, -1.0),
        vec2<f32>(-1.0,  1.0),
        vec2<f32>( 1.0,  1.0),
    );
    let pos = positions[i32(in.index)];
    let virtual_pos = pos * u_stdinfo.ndc_offset.xy + u_stdinfo.ndc_offset.zw;
    var varyings: Varyings;
    varyings.position = vec4<f32>(pos, 0.9999999, 1.0);
    varyings.texcoord = vec3<f32>(virtual_pos * 0.5 + 0.5, 0.0);
    varyings.ndc = vec2<f32>(pos);
    return varyings;
}

// The ground's colour (sRGB, already lit) at ground point `hit`, `dist` metres from the camera
// (twin: reference.ground_albedo): soil under the field (darker the more the grass covers it),
// the ground beyond it; for a field to the horizon (m.horizon.w != 0) the grass seen from afar
// takes over with the camera's distance (m.far_blend.x..y) and wholly past the last blades
// (m.horizon.z): the blades' colour at m.far_blend.w of their height, in the same patches
// (clump_noise of size m.far_blend.z) as the blades, times their mean shade (m.far_grass).
// `sunlight` (shadows.wgsl's ground_sunlight, 1 with shadows off) lights the soil and the ground
// beyond; the far grass is the grass's top, lit as the blades are.
fn ground_albedo(hit: vec3<f32>, dist: f32, sunlight: f32) -> vec3<f32> {
    let m = u_material;
    let inside = field_inside(hit.x, hit.z, m.field.xy, m.field.zw, m.field_edge);
    var ground = ground_color(m.soil_color.rgb, m.beyond_color.rgb, inside, m.cover) * sunlight;
    // No branch on a uniform alone (lavapipe recompiles such a shader at each draw, see blade_render.wgsl):
    // horizon.w (0 or 1) scales the share, and the branch reads the pixel's share.
    // Compiled in only for a field to the horizon (template switch `far_grass`: the kernel's
    // SkyGroundMaterial.far_grass follows horizon.w; the browser engine always compiles it in):
    // lavapipe runs the branch's noise on every ground pixel even where no pixel takes it.
    $$ if far_grass
    let r = length(hit.xz - m.horizon.xy);
    let far = m.horizon.w * max(smoothstep(m.far_blend.x, m.far_blend.y, dist),
                                smoothstep(m.horizon.z - 2.0 * m.field_edge, m.horizon.z, r));
    if (far > 0.0) {
        let clump = clump_noise(hit.x, hit.z, m.far_blend.z);
        let grass = blade_base_color(m.grass_root.rgb, m.grass_tip.rgb, m.far_blend.w, 0.5, clump,
                                     m.color_variation, m.dryness) * m.far_grass.rgb;
        ground = mix(ground, grass, far);
    }
    $$ endif
    return ground;
}

@fragment
fn fs_main(varyings: Varyings) -> FragmentOutput {
    let near = ndc_to_world_pos(vec4<f32>(varyings.ndc, 0.0, 1.0));
    let far = ndc_to_world_pos(vec4<f32>(varyings.ndc, 1.0, 1.0));
    let dir = far - near;
    let m = u_material;
    let g = m.ground;
    let elevation = dir.y / max(length(dir), 1e-20);
    var rgb = sky_color(elevation, m.horizon_color.rgb, m.zenith_color.rgb);
    if (m.show_ground != 0 && abs(dir.y) > 1e-12) {
        let s = (g.y - near.y) / dir.y;
        if (s > 0.0) {
            let hit = near + s * dir;
            // inside the square, and nearer than the far plane (where a mesh would be clipped)
            let clip = u_stdinfo.projection_transform * u_stdinfo.cam_transform * vec4<f32>(hit, 1.0);
            if (abs(hit.x - g.x) <= g.w && abs(hit.z - g.z) <= g.w && clip.z <= clip.w) {
                let cam = u_stdinfo.cam_transform_inv[3].xyz;
                let dist = length(hit - cam);
                // lit by the sun past the balls and the grass (shadows.wgsl; 1 with shadows off)
                let ground = ground_albedo(hit, dist, ground_sunlight(hit, m.ground_sun));
                // the ground fades into the horizon over the last 40 % before the far plane
                // (view depth clip.w; m.far_distance), and into the fog
                let fade = max(smoothstep(0.6, 1.0, clip.w / m.far_distance), fog_amount(dist, m.fog_density));
                rgb = mix(ground, m.horizon_color.rgb, fade);
            }
        }
    }
    var out: FragmentOutput;
    out.color = vec4<f32>(srgb2physical(rgb), 1.0);
    $$ if write_pick
    out.pick = pick_pack(u32(u_wobject.global_id), 20);
    $$ endif
    return out;
}
