// The compute rasterizer's resolve (raster.wgsl): one draw across the pixel rows the walks wrote. Each pixel
// a compute-rasterized blade covers is shaded like the ribbons shade it
// (blade_math.blade_shade at the blade's curve point v, with the ribbon's normal and
// the looks' base colour, glow and fog) and written with that blade's depth (frag_depth), so the
// ordinary depth test composites it with the hardware-drawn blades, the ground and
// sky, the balls and any other object. Pixels no such blade covers are discarded.
//
// With teaching_views and u_cull.color_by "lod", these blades are flat in
// RASTER_COLOR (teaching.COMPUTE_RASTER_COLOR: "drawn in compute").
//
// Bindings (the engine's): u_stdinfo, u_wobject, u_cull (storage), u_material,
// s_blades, s_raster_depth and s_raster_payload (array<u32>, read; with raster_packed
// s_raster_depth holds both, two words per pixel, raster.wgsl), s_raster_args
// (array<u32>, read: blades listed and rows written, raster.wgsl).

{$ include 'pygfx.std.wgsl' $}
{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
{$ include 'grasswidget.shadows.wgsl' $}

$$ if teaching_views
const RASTER_COLOR = vec3<f32>({{ raster_color }});
$$ endif

struct VertexInput {
    @builtin(vertex_index) index : u32,
};

@vertex
fn vs_main(in: VertexInput) -> Varyings {
    // The rows the compute rasterizer wrote this frame (raster.wgsl, s_raster_args[2] ..
    // ~s_raster_args[3], pixel rows from the top): a quad across the view over those rows
    // only, so no other pixel runs the fragment shader (on a CPU adapter a full-screen pass
    // that writes frag_depth costs as much as the whole sky and ground). None written (no
    // blade listed, or all outside the view): a quad of zero area.
    let first_row = f32(s_raster_args[2]);
    let last_row = f32(~s_raster_args[3]);
    let height = u_stdinfo.physical_size.y;
    let top = 1.0 - 2.0 * clamp(first_row, 0.0, height) / height;
    let bottom = 1.0 - 2.0 * clamp(last_row + 1.0, 0.0, height) / height;
    let written = select(0.0, 1.0, s_raster_args[2] <= ~s_raster_args[3]);
    var positions = array<vec2<f32>, 4>(
        vec2<f32>(-1.0, bottom),
        vec2<f32>( 1.0, bottom),
        vec2<f32>(-1.0, top),
        vec2<f32>( 1.0, top),
    );
    var varyings: Varyings;
    varyings.position = vec4<f32>(positions[i32(in.index)] * written, 0.5, 1.0);
    return varyings;
}

@fragment
fn fs_main(varyings: Varyings) -> FragmentOutput {
    let pixel = vec2<u32>(floor(varyings.position.xy));
    if (pixel.x >= u32(u_cull.raster_width) || pixel.y >= u32(u_cull.raster_height)) {
        discard;
    }
    let index = pixel.y * u32(u_cull.raster_width) + pixel.x;
    $$ if raster_packed
    // One walk (raster.wgsl): a u64 per pixel, the depth's bits high, the payload's complement low.
    let depth = s_raster_depth[2u * index + 1u];
    let payload = ~s_raster_depth[2u * index];
    $$ else
    let depth = s_raster_depth[index];
    let payload = s_raster_payload[index];
    $$ endif
    if (depth == 0xffffffffu) {
        discard;
    }
    let blade = payload >> 8u;
    let v = f32(payload & 255u) / 255.0;
    let rec = load_blade(blade);
    // The ribbon's curve point, tangent and normal at v (blade_render.wgsl).
    let a = rec.v0 + v * (rec.v1 - rec.v0);
    let b = rec.v1 + v * (rec.v2 - rec.v1);
    let c = a + v * (b - a);
    let t1 = width_direction(rec.up, rec.orientation);
    var t0 = b - a;
    if (dot(t0, t0) < 1e-12) { t0 = rec.up; }
    let n = cross(normalize(t0), t1);
    let world_pos = (u_wobject.world_transform * vec4<f32>(c, 1.0)).xyz;
    let world_normal = (u_wobject.world_transform * vec4<f32>(n, 0.0)).xyz;
    let cam_pos = u_stdinfo.cam_transform_inv[3].xyz;
    // The blade's colour like the ribbons' vertices give it (blade_render.wgsl): its
    // patch (clump noise of the root), its hash, the glow against the sun and the fog.
    let eye = cam_pos - world_pos;
    let clump = clump_noise(rec.v0.x, rec.v0.z, u_material.patch_size);
    let base = blade_base_color(u_material.root_color.rgb, u_material.tip_color.rgb, v, hash01(blade), clump,
                                u_material.color_variation, u_material.dryness);
    let glow = backlight(normalize(eye), normalize(u_material.light_direction.xyz), v, u_material.translucency);
    let fog = fog_amount(length(eye), u_material.fog_density);
    let sunlit = blade_sunlight(world_pos, v, u_material.ambient);  // shadows.wgsl, as the ribbons
    var rgb = blade_shade(world_normal, normalize(eye), v, base * sunlit.x, glow * sunlit.y, fog, u_material.fog_color.rgb,
                          u_material.light_direction.xyz, u_material.ambient);
    $$ if teaching_views
    if (u_cull.color_by == {{ color_by_lod }}) { rgb = RASTER_COLOR; }
    $$ endif

    var out: FragmentOutput;
    out.color = vec4<f32>(srgb2physical(rgb), u_material.opacity);
    out.depth = bitcast<f32>(depth);
    $$ if write_pick
    out.pick = (
        pick_pack(u32(u_wobject.global_id), 20) +
        pick_pack(blade, 26)
    );
    $$ endif
    return out;
}
