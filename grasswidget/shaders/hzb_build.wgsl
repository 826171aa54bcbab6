// One level of the max-depth pyramid of the occlusion test: texel (x, y) of level
// {{ level }} is the farthest of texels (2x..2x+1, 2y..2y+1) of level {{ level - 1 }}
// (clamped at the edges). Level 0 is this frame's depth buffer, copied in by the
// engine (rows every pitch texels). The twin of reference.build_hzb().
//
// Engine-neutral: the engine declares s_hzb (array<f32>, read_write) and
// s_hzb_levels (array<vec4<u32>>, read; see occlusion.wgsl) and dispatches
// ceil(width / 8) x ceil(height / 8) workgroups of the level's size.

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let src = s_hzb_levels[{{ level }}u];       // level - 1 (entry 0 is the header)
    let dst = s_hzb_levels[{{ level }}u + 1u];
    if (gid.x >= dst.y || gid.y >= dst.z) {
        return;
    }
    let x0 = 2u * gid.x;
    let y0 = 2u * gid.y;
    let x1 = min(x0 + 1u, src.y - 1u);
    let y1 = min(y0 + 1u, src.z - 1u);
    let a = max(s_hzb[src.x + y0 * src.w + x0], s_hzb[src.x + y0 * src.w + x1]);
    let b = max(s_hzb[src.x + y1 * src.w + x0], s_hzb[src.x + y1 * src.w + x1]);
    s_hzb[dst.x + gid.y * dst.w + gid.x] = max(a, b);
}
