// Sky and ground in one full-screen pass (SkyGround, grasswidget/gpu/sky_ground.py).
// Drawn after the opaque objects at the far depth with the "<" depth test, so only
// the pixels nothing else covered are shaded. Per pixel: the view ray meets the
// ground plane y = ground.y inside the square of half-size ground.w around
// ground.xz, nearer than the far plane -> the flat ground colour; else the sky gradient (bottom -> top of
// the view, like pygfx's two-colour Background).

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
    let pos = positions[i32(in.index)];
    let virtual_pos = pos * u_stdinfo.ndc_offset.xy + u_stdinfo.ndc_offset.zw;
    var varyings: Varyings;
    varyings.position = vec4<f32>(pos, 0.9999999, 1.0);
    varyings.texcoord = vec3<f32>(virtual_pos * 0.5 + 0.5, 0.0);
    varyings.ndc = vec2<f32>(pos);
    return varyings;
}

@fragment
fn fs_main(varyings: Varyings) -> FragmentOutput {
    let near = ndc_to_world_pos(vec4<f32>(varyings.ndc, 0.0, 1.0));
    let far = ndc_to_world_pos(vec4<f32>(varyings.ndc, 1.0, 1.0));
    let dir = far - near;
    let g = u_material.ground;
    var rgb = mix(u_material.sky_bottom.rgb, u_material.sky_top.rgb, varyings.texcoord.y);
    if (u_material.show_ground != 0 && abs(dir.y) > 1e-12) {
        let s = (g.y - near.y) / dir.y;
        if (s > 0.0) {
            let hit = near + s * dir;
            // inside the square, and nearer than the far plane (where a mesh would be clipped)
            let clip = u_stdinfo.projection_transform * u_stdinfo.cam_transform * vec4<f32>(hit, 1.0);
            if (abs(hit.x - g.x) <= g.w && abs(hit.z - g.z) <= g.w && clip.z <= clip.w) {
                rgb = u_material.ground_color.rgb;
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
