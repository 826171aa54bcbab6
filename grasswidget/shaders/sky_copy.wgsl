// The sky and ground of the last frames, copied (gpu/sky_ground.py, SkyGroundCache): while the camera,
// the view's size and every sky/ground value stay what they were, the kernel engine draws the picture
// sky_ground.wgsl drew into a texture of the view's size once, instead of shading every pixel the grass
// leaves open again. Drawn like the sky and ground: after the grass, at the same far depth behind the
// "<" depth test (no discard, no depth write: the early depth test keeps), so the same pixels are
// written, each with the colour sky_ground.wgsl gave it there (the texture holds the target's format).
//
// Bindings: u_stdinfo, u_wobject, u_material (SkyCopyMaterial: sky_id, the sky's pick id), t_sky
// (texture_2d<f32>, the view's size).

{$ include 'pygfx.std.wgsl' $}

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
    var varyings: Varyings;
    varyings.position = vec4<f32>(positions[in.index], 0.9999999, 1.0);  // sky_ground.wgsl's depth
    return varyings;
}

@fragment
fn fs_main(varyings: Varyings) -> FragmentOutput {
    let texel = textureLoad(t_sky, vec2<i32>(floor(varyings.position.xy)), 0);
    var out: FragmentOutput;
    out.color = vec4<f32>(texel.rgb, 1.0);
    $$ if write_pick
    out.pick = pick_pack(u_material.sky_id, 20);
    $$ endif
    return out;
}
