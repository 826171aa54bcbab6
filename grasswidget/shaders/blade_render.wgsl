// Draw every visible blade of one level-of-detail class as a ribbon, by vertex
// pulling: no vertex buffers. Instance i is the i-th entry of the class's
// compacted list (with from_end, the second occlusion phase's, counted from the end); vertex k of its triangle strip is row k/2 (v = row / segments)
// and side k%2 (u). Ribbon formulas: paper section 6 / reference ribbons.
//
// Colouring, with teaching_views (the pygfx engine): u_cull.color_by 0 natural (lit), 1 "lod" (flat, the class's
// colour, teaching.LOD_COLORS), 2 "cull" (kept blades natural; the extra draw of
// culled blades, `culled`, is flat in the colour of the test that culled each
// one, teaching.CULL_COLORS). Flat colours are sRGB, unlit.

{$ include 'pygfx.std.wgsl' $}
{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.shadows.wgsl' $}
$$ if follow_camera
{$ include 'grasswidget.levels.wgsl' $}
$$ endif

const SEGMENTS: u32 = {{ segments }}u;
const LOD_CLASS: u32 = {{ lod_class }}u;
$$ if teaching_views
const LOD_COLOR = vec3<f32>({{ lod_color }});

// sRGB colour of a blade culled by test `reason` (1 orientation, 2 frustum, 3 distance, 4 occlusion).
fn cull_color(reason: u32) -> vec3<f32> {
    switch reason {
        case 1u: { return vec3<f32>({{ cull_colors[0] }}); }
        case 2u: { return vec3<f32>({{ cull_colors[1] }}); }
        case 3u: { return vec3<f32>({{ cull_colors[2] }}); }
        default: { return vec3<f32>({{ cull_colors[3] }}); }
    }
}
$$ endif

struct VertexInput {
    @builtin(vertex_index) vertex_index: u32,
    @builtin(instance_index) instance_index: u32,
};

@vertex
fn vs_main(in: VertexInput) -> Varyings {
    $$ if teaching_views and culled
    let entry = s_culled[in.instance_index];
    let blade = entry & 0x1fffffffu;
    let flat_color = vec4<f32>(cull_color(entry >> 29u), 1.0);
    $$ else
    $$ if from_end
    // The second phase of occlusion culling lists its blades from the end (cull.wgsl).
    let blade = s_visible[LOD_CLASS * u_cull.n_blades + u_cull.n_blades - 1u - in.instance_index];
    $$ else
    let blade = s_visible[LOD_CLASS * u_cull.n_blades + in.instance_index];
    $$ endif
    $$ endif
    $$ if teaching_views and not culled
    var flat_color = vec4<f32>(0.0);  // a = 1: draw flat in rgb (sRGB)
    if (u_cull.color_by == {{ color_by_lod }}) { flat_color = vec4<f32>(LOD_COLOR, 1.0); }
    $$ endif
    let rec = load_blade(blade);
    let v0 = rec.v0;
    let v1 = rec.v1;
    let v2 = rec.v2;
    $$ if follow_camera
    // A field to the horizon: the blade's level weight (0..1, levels.wgsl) scales its drawn width.
    let width = rec.width * blade_weight(blade, v0);
    $$ else
    let width = rec.width;
    $$ endif

    let row = in.vertex_index / 2u;
    let u = f32(in.vertex_index % 2u);
    let v = f32(row) / f32(SEGMENTS);

    // De Casteljau on the quadratic Bezier v0, v1, v2.
    let a = v0 + v * (v1 - v0);
    let b = v1 + v * (v2 - v1);
    let c = a + v * (b - a);
    let t1 = width_direction(rec.up, rec.orientation);
    var t0 = b - a;
    if (dot(t0, t0) < 1e-12) { t0 = rec.up; }
    t0 = normalize(t0);
    let n = normalize(cross(t0, t1));
    let c0 = c - width * t1;
    let c1 = c + width * t1;
    // The shape through a select on per-blade data (a width is never negative), so that no
    // branch reads a uniform alone: Mesa 22.3 lavapipe compiles, and never frees, a copy of
    // such a shader on every draw (1.4 MB a frame here; benchmarks/lavapipe_inline_uniform_leak.py).
    let shape = select(u_material.blade_shape, -7, width < -1.0);
    let t = blade_shape_t(u, v, shape, u_material.tip_threshold);
    var pos = (1.0 - t) * c0 + t * c1;
    if (shape == {{ blade_shape_fold }}) {
        pos = pos + n * (width * (0.5 - abs(u - 0.5) * (1.0 - v)));
    }

    let world_pos = u_wobject.world_transform * vec4<f32>(pos, 1.0);
    let world_normal = normalize((u_wobject.world_transform * vec4<f32>(n, 0.0)).xyz);
    let clip = u_stdinfo.projection_transform * u_stdinfo.cam_transform * world_pos;

    var varyings: Varyings;
    varyings.position = vec4<f32>(clip);
    let eye = u_stdinfo.cam_transform_inv[3].xyz - world_pos.xyz / world_pos.w;
    // The blade's unlit colour: its patch (clump noise of the root) and its own hash.
    let clump = clump_noise(v0.x, v0.z, u_material.patch_size);
    let base = blade_base_color(u_material.root_color.rgb, u_material.tip_color.rgb, v, hash01(blade), clump,
                                u_material.color_variation, u_material.dryness);
    $$ if shade_per_vertex
    // Ribbons of 4 or more segments (the near blades, every blade without LOD) are shaded per
    // vertex: blade_shade of the looks (diffuse and translucency, the tips' glow against the
    // sun, the fog) goes to the fragments as one sRGB colour, interpolated in sRGB like the base
    // colour (in linear light the blades came out a level brighter). Every term is smooth along
    // the blade and the same across it (the normal is the row's), so 4+ rows of colour stay
    // within a fraction of a level of the per-fragment shading. On a CPU adapter these blades'
    // fragments and each interpolated float cost more than their vertices (benchmarks/README.md,
    // "The looks' fragment cost on lavapipe"): 8 values a vertex (position, colour, pick id), were
    // 16. The coarser ribbons (1-2 segments: far, few pixels each) keep the per-fragment shading
    // below: their colour would be one ramp from root to tip.
    let eye_distance = max(length(eye), 1e-12);
    let to_eye = eye / eye_distance;
    let glow = backlight(to_eye, normalize(u_material.light_direction.xyz), v, u_material.translucency);
    // The sunlight's shadows and darkened roots (shadows.wgsl; (1, 1) with shadows off), per vertex too.
    let sunlit = blade_sunlight(world_pos.xyz / world_pos.w, v, u_material.ambient);
    var rgb = blade_shade(world_normal, to_eye, v, base * sunlit.x, glow * sunlit.y,
                          fog_amount(eye_distance, u_material.fog_density), u_material.fog_color.rgb,
                          u_material.light_direction.xyz, u_material.ambient);
    $$ if teaching_views
    if (flat_color.a > 0.5) { rgb = flat_color.rgb; }
    $$ endif
    varyings.color = vec3<f32>(rgb);
    $$ else
    varyings.world_pos = vec3<f32>(world_pos.xyz / world_pos.w);
    varyings.normal = vec3<f32>(world_normal);
    varyings.along = f32(v);
    varyings.base_color = vec3<f32>(base);
    // The distance fog per vertex (an exp per fragment is dear on a CPU adapter). The
    // tips' glow is per fragment: one more varying (17 floats a vertex with the position
    // and the pick id, over 16) made the H100's meadow draw 25 % slower.
    varyings.fog = f32(fog_amount(length(eye), u_material.fog_density));
    $$ if teaching_views
    varyings.flat_color = vec4<f32>(flat_color);
    $$ endif
    $$ endif
    varyings.pick_idx = u32(blade);
    return varyings;
}

@fragment
fn fs_main(varyings: Varyings) -> FragmentOutput {
    $$ if shade_per_vertex
    // The vertices' shading (sRGB, see vs_main), interpolated.
    let rgb = varyings.color;
    $$ else
    let cam_pos = u_stdinfo.cam_transform_inv[3].xyz;
    let to_eye = normalize(cam_pos - varyings.world_pos);
    let glow = backlight(to_eye, normalize(u_material.light_direction.xyz), varyings.along, u_material.translucency);
    // The sunlight's shadows and darkened roots (shadows.wgsl; (1, 1) with shadows off).
    let sunlit = blade_sunlight(varyings.world_pos, varyings.along, u_material.ambient);
    // Two-sided diffuse and translucency, the tips' glow against the sun and the fog
    // (blade_math.blade_shade; base colour and fog from the vertices).
    var rgb = blade_shade(varyings.normal, to_eye, varyings.along, varyings.base_color * sunlit.x, glow * sunlit.y,
                          varyings.fog, u_material.fog_color.rgb, u_material.light_direction.xyz,
                          u_material.ambient);
    $$ if teaching_views
    if (varyings.flat_color.a > 0.5) { rgb = varyings.flat_color.rgb; }
    $$ endif
    $$ endif
    var out: FragmentOutput;
    out.color = vec4<f32>(srgb2physical(rgb), u_material.opacity);
    $$ if write_pick
    out.pick = (
        pick_pack(u32(u_wobject.global_id), 20) +
        pick_pack(varyings.pick_idx, 26)
    );
    $$ endif
    return out;
}
