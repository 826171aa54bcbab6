// The compute rasterizer's resolve (raster.wgsl): one draw across the pixel rows the walks wrote. Each pixel
// a compute-rasterized blade covers is written in the colour raster.wgsl's step "shade" gave it
// (blade_math.blade_shade at the blade's curve point v, with the ribbon's normal and
// the looks' base colour, glow and fog: the ribbons' shading) with that blade's depth (frag_depth), so the
// ordinary depth test composites it with the hardware-drawn blades, the ground and
// sky, the balls and any other object. Pixels no such blade covers are discarded.
//
// With teaching_views and u_cull.color_by "lod", the shade step made these blades flat in
// RASTER_COLOR (teaching.COMPUTE_RASTER_COLOR: "drawn in compute").
//
// Bindings (the engine's): u_stdinfo, u_wobject, u_cull (storage), u_material (opacity),
// s_raster_depth and s_raster_payload (array<u32>, read; with raster_packed
// s_raster_depth holds both, two words per pixel, raster.wgsl), s_raster_color (array<u32>,
// read: two words per pixel, raster.wgsl's step "shade"), s_raster_args
// (array<u32>, read: blades listed and rows written, raster.wgsl).

{$ include 'pygfx.std.wgsl' $}

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
    // The pixel's colour, shaded by raster.wgsl's step "shade" (f16 pairs: r g, b): on a GPU whose
    // fragment units are few, the shading per pixel costs a compute pass a fraction of a fragment pass.
    let rgb = vec3<f32>(unpack2x16float(s_raster_color[2u * index]), unpack2x16float(s_raster_color[2u * index + 1u]).x);
    var out: FragmentOutput;
    out.color = vec4<f32>(srgb2physical(rgb), u_material.opacity);
    out.depth = bitcast<f32>(depth);
    $$ if write_pick
    out.pick = (
        pick_pack(u32(u_wobject.global_id), 20) +
        pick_pack(payload >> 8u, 26)
    );
    $$ endif
    return out;
}
