// The browser engine's stand-in for pygfx.std.wgsl, included by the project's
// render shaders (blade_render.wgsl, sky_ground.wgsl) in place of pygfx's std
// include: the varyings (generated from the shader's `varyings.x = T(...)` lines,
// as pygfx does), the fragment output and the helpers those files call. The
// canvas stores sRGB values directly, so srgb2physical is the identity here
// (pygfx converts to linear and its output pass converts back: the same pixels
// for opaque surfaces). With the template variable frag_depth the fragment output
// also carries its depth (raster_resolve.wgsl writes the compute-rasterized blades' depth).

/*__GRASSWIDGET_VARYINGS__*/

struct FragmentOutput {
    @location(0) color: vec4<f32>,
$$ if frag_depth
    @builtin(frag_depth) depth: f32,
$$ endif
};

fn srgb2physical(color: vec3<f32>) -> vec3<f32> {
    return color;
}

// World position of a normalized device coordinate (pygfx's helper of the same name).
fn ndc_to_world_pos(ndc_pos: vec4<f32>) -> vec3<f32> {
    let world_pos = u_stdinfo.cam_transform_inv * u_stdinfo.projection_transform_inv * ndc_pos;
    return world_pos.xyz / world_pos.w;
}
