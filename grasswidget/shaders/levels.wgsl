// Camera-following levels of a field to the horizon (core/horizon.py): each blade's level and
// weight (blade_weight), which scales its drawn width
// (blade_render.wgsl, raster.wgsl) and culls it at 0 (cull.wgsl). Included after blade.wgsl and
// blade_math.wgsl by the shaders rendered with the template variable follow_camera (only for such
// a field: other fields compile none of it). The twins: reference.blade_weights (the wrap, cull.wgsl's
// follow_camera, reference.follow_camera).
//
// Engine-neutral: the engine declares u_stdinfo (cam_transform_inv), u_wobject
// (world_transform_inv), u_cull (frozen, frozen_cam_pos, level_bands, level_periods, level_ends,
// n_levels: uniform_layouts.CULL_LAYOUT, written once from HorizonLayout.table) and s_blades
// (read).

// The culling camera (the frozen one while culling is frozen) in the field's own space (m).
fn levels_camera() -> vec3<f32> {
    let render_cam = u_stdinfo.cam_transform_inv[3].xyz;
    let cam = select(render_cam, u_cull.frozen_cam_pos.xyz, u_cull.frozen != 0);
    return (u_wobject.world_transform_inv * vec4<f32>(cam, 1.0)).xyz;
}

// Level of blade i (level_index of the table).
fn blade_level(i: u32) -> u32 {
    return level_index(i, u_cull.level_ends[0], u_cull.level_ends[1], u_cull.n_levels);
}

// Weight of blade i with root v0 (the field's space): its level's weight at the horizontal distance
// (x, z) from the culling camera to the root, so that the grass within 10 m of the camera is as dense
// from a high camera (the "top" preset) as from one over the grass.
fn blade_weight(i: u32, v0: vec3<f32>) -> f32 {
    return level_weight(length((v0 - levels_camera()).xz), u_cull.level_bands[blade_level(i)]);
}
