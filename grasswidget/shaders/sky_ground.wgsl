// Sky and ground (SkyGround, grasswidget/gpu/sky_ground.py), drawn after the opaque objects at
// the far depth with the "<" depth test (no discard, no depth write: the early depth test keeps),
// so only the pixels nothing else covered are shaded. Per pixel: the view ray meets the ground
// plane y = ground.y inside the square of half-size ground.w around ground.xz, nearer than the far
// plane -> the ground: soil under the field (the rectangle `field`, darker the more the grass
// covers it), beyond it the grass seen from afar (ground_albedo), fading towards the horizon
// colour near the far plane and with distance fog; else the sky, from the horizon colour up to
// the zenith colour by the ray's elevation (functions: blade_math.wgsl, looks). With
// GrassParams.shadows the ground is lit past the balls and the grass (shadows.wgsl).
//
// Template switch `part`: "all" draws the whole screen, every pixel choosing sky or ground (the
// browser engine); "sky" and "ground" draw two pieces of the screen split by the line where the
// view ray turns from rising to falling towards the ground (the kernel engine: two draws, one
// material), so the sky's pixels never run the ground's maths (on a CPU both sides of a branch
// run). The ground's piece still falls back to the sky where its ray misses the ground square or
// meets it past the far plane, so the two draws give the picture of "all".

{$ include 'pygfx.std.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.shadows.wgsl' $}

struct VertexInput {
    @builtin(vertex_index) index : u32,
};

$$ if part == "all"
// The whole screen: a strip of 4 vertices.
fn screen_vertex(index: u32) -> vec2<f32> {
    var positions = array<vec2<f32>, 4>(
        vec2<f32>(-1.0, -1.0),
        vec2<f32>( 1.0, -1.0),
        vec2<f32>(-1.0,  1.0),
        vec2<f32>( 1.0,  1.0),
    );
    return positions[index];
}
$$ else
// How the view ray through screen point `ndc` meets the ground plane: > 0 where it falls towards
// it (or rises towards it from below), the ground's side. The ray's rise (the far point's height
// minus the near point's) is affine in ndc for a perspective or orthographic camera (the
// unprojection's w does not depend on x, y), so the four corners give the split line exactly.
fn ground_side(ndc: vec2<f32>) -> f32 {
    let rise = ndc_to_world_pos(vec4<f32>(ndc, 1.0, 1.0)).y - ndc_to_world_pos(vec4<f32>(ndc, 0.0, 1.0)).y;
    let below = u_material.ground.y - u_stdinfo.cam_transform_inv[3].y;  // < 0: the camera above the ground
    return select(-1.0, rise * below, u_material.show_ground != 0);
}

// Vertex `index` (0..8, a list of 3 triangles) of the screen's piece on this part's side of the
// split: the screen square clipped by the line (at most 5 corners), as a fan; triangles past the
// piece's corners are empty. Both parts compute the same crossing points (the same sums of the
// same corner values), so their pieces meet without a gap or an overlap.
fn screen_vertex(index: u32) -> vec2<f32> {
    var square = array<vec2<f32>, 4>(
        vec2<f32>(-1.0, -1.0),
        vec2<f32>( 1.0, -1.0),
        vec2<f32>( 1.0,  1.0),
        vec2<f32>(-1.0,  1.0),
    );
    var side = array<f32, 4>(ground_side(square[0]), ground_side(square[1]), ground_side(square[2]),
                             ground_side(square[3]));
    var piece = array<vec2<f32>, 6>(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0),
                                    vec2<f32>(0.0), vec2<f32>(0.0));
    var count = 0u;
    for (var i = 0u; i < 4u; i = i + 1u) {
        let j = (i + 1u) % 4u;
        $$ if part == "ground"
        let in_i = side[i] > 0.0;
        let in_j = side[j] > 0.0;
        $$ else
        let in_i = !(side[i] > 0.0);
        let in_j = !(side[j] > 0.0);
        $$ endif
        if (in_i) {
            piece[count] = square[i];
            count = count + 1u;
        }
        if (in_i != in_j) {
            piece[count] = square[i] + (square[j] - square[i]) * (side[i] / (side[i] - side[j]));
            count = count + 1u;
        }
    }
    let triangle = index / 3u;
    let corner = index % 3u;
    if (triangle + 2u >= count) {
        return vec2<f32>(2.0, 2.0);  // an empty triangle (all three corners at one point, off screen)
    }
    return piece[select(triangle + corner, 0u, corner == 0u)];
}
$$ endif

@vertex
fn vs_main(in: VertexInput) -> Varyings {
    let pos = screen_vertex(in.index);
    let virtual_pos = pos * u_stdinfo.ndc_offset.xy + u_stdinfo.ndc_offset.zw;
    var varyings: Varyings;
    varyings.position = vec4<f32>(pos, 0.9999999, 1.0);
    varyings.texcoord = vec3<f32>(virtual_pos * 0.5 + 0.5, 0.0);
    varyings.ndc = vec2<f32>(pos);
    // The view ray's ends (world space, on the near and far planes) and their clip w: affine in the
    // screen position for a perspective or orthographic camera, so the interpolated values are the
    // pixel's own (w = 1 here: linear interpolation), and no pixel unprojects (matrix products per
    // pixel were most of the ground's arithmetic on a CPU).
    let near = ndc_to_world_pos(vec4<f32>(pos, 0.0, 1.0));
    let far = ndc_to_world_pos(vec4<f32>(pos, 1.0, 1.0));
    let to_clip = u_stdinfo.projection_transform * u_stdinfo.cam_transform;
    varyings.ray_near = vec3<f32>(near);
    varyings.ray_far = vec3<f32>(far);
    varyings.ray_w = vec2<f32>((to_clip * vec4<f32>(near, 1.0)).w, (to_clip * vec4<f32>(far, 1.0)).w);
    return varyings;
}

// The ground's colour (sRGB, already lit) at ground point `hit`, `dist` metres from the camera
// (twin: reference.ground_albedo): soil under the field (darker the more the grass covers it);
// beyond it the grass seen from afar (m.far_grass.w = 1; 0: the bare plain m.beyond_color):
// the blades' colour at m.far_blend.w of their height, in the same patches (clump noise of size
// m.far_blend.z) as the blades, times their mean shade (m.far_grass.rgb); for a field to the
// horizon (m.horizon.w != 0) the far grass also takes over the soil with the camera's distance
// (m.far_blend.x..y) and wholly past the last blades (m.horizon.z). `sunlight` (shadows.wgsl's
// ground_sunlight, 1 with shadows off) lights the soil and the ground beyond the field (far grass or
// plain: the balls' shadows fall on it); the far grass over a field to the horizon is the grass's
// top, lit as the blades are.
fn ground_albedo(hit: vec3<f32>, dist: f32, sunlight: f32) -> vec3<f32> {
    let m = u_material;
    let inside = field_inside(hit.x, hit.z, m.field.xy, m.field.zw, m.field_edge);
    let soil = m.soil_color.rgb * sunlight;
    // Compiled in while the ground shows far grass (template switch `far_grass`: the kernel's
    // SkyGroundMaterial.far_grass follows far_grass.w and horizon.w; the browser engine always
    // compiles it in): lavapipe runs it on every ground pixel, the soil's too (no branch on a uniform
    // alone: lavapipe recompiles such a shader at each draw, see blade_render.wgsl). Its two simplex
    // noises cost about 4 ms each of the default 640 x 480 view on lavapipe while simplex_corner
    // indexed its gradients (a gather per vector lane); by selects, nothing measurable.
    $$ if far_grass
    let clump = clump_noise(hit.x, hit.z, m.far_blend.z);
    let grass = blade_base_color(m.grass_root.rgb, m.grass_tip.rgb, m.far_blend.w, 0.5, clump,
                                 m.color_variation, m.dryness) * m.far_grass.rgb;
    // beyond the field the far grass takes the bare plain's place, lit as it was (the balls' shadows, the
    // field's shadow past its edge); over a field to the horizon it is the grass's top (`far`, unlit)
    let beyond = mix(m.beyond_color.rgb, grass, m.far_grass.w) * sunlight;
    let ground = ground_color(soil, beyond, inside, m.cover);
    let r = length(hit.xz - m.horizon.xy);
    let far = m.horizon.w * max(smoothstep(m.far_blend.x, m.far_blend.y, dist),
                                smoothstep(m.horizon.z - 2.0 * m.field_edge, m.horizon.z, r));
    return mix(ground, grass, far);
    $$ else
    return ground_color(soil, m.beyond_color.rgb * sunlight, inside, m.cover);
    $$ endif
}

@fragment
fn fs_main(varyings: Varyings) -> FragmentOutput {
    let near = varyings.ray_near;
    let dir = varyings.ray_far - near;
    let m = u_material;
    let g = m.ground;
    let elevation = dir.y / max(length(dir), 1e-20);
    var rgb = sky_color(elevation, m.horizon_color.rgb, m.zenith_color.rgb);
    $$ if part != "sky"
    if (m.show_ground != 0 && abs(dir.y) > 1e-12) {
        let s = (g.y - near.y) / dir.y;
        if (s > 0.0) {
            let hit = near + s * dir;
            // inside the square, and nearer than the far plane (where a mesh would be clipped): the
            // hit's clip z is s times the far end's w (the near end's z is 0), its clip w
            // mix(ray_w.x, ray_w.y, s), so clip z <= clip w is s <= 1 (the near end's w > 0)
            let clip_w = mix(varyings.ray_w.x, varyings.ray_w.y, s);
            if (abs(hit.x - g.x) <= g.w && abs(hit.z - g.z) <= g.w && s <= 1.0) {
                let cam = u_stdinfo.cam_transform_inv[3].xyz;
                let dist = length(hit - cam);
                // lit by the sun past the balls and the grass (shadows.wgsl; 1 with shadows off)
                let ground = ground_albedo(hit, dist, ground_sunlight(hit, m.ground_sun));
                // the ground fades into the horizon over the last 40 % before the far plane
                // (view depth clip_w; m.far_distance), and into the fog
                let fade = max(smoothstep(0.6, 1.0, clip_w / m.far_distance), fog_amount(dist, m.fog_density));
                rgb = mix(ground, m.horizon_color.rgb, fade);
            }
        }
    }
    $$ endif
    var out: FragmentOutput;
    out.color = vec4<f32>(srgb2physical(rgb), 1.0);
    $$ if write_pick
    out.pick = pick_pack(u32(u_wobject.global_id), 20);
    $$ endif
    return out;
}
