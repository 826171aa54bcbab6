// One level of the max-depth pyramid of the occlusion test: texel (x, y) of level
// {{ level }} is the farthest of texels (2x..2x+1, 2y..2y+1) of the level below
// (clamped at the edges). Level 0 is this frame's depth buffer, copied in by the
// engine (rows every pitch texels). The twin of reference.build_hzb().
//
// Engine-neutral: the engine declares s_hzb (array<f32>, read_write) and
// s_hzb_levels (array<vec4<u32>>, read; see occlusion.wgsl) and dispatches
// ceil(width / 8) x ceil(height / 8) workgroups of the level's size.
//
// With template variable last_level > level (the kernel engine's small levels): levels
// {{ level }} .. last_level in one workgroup of 64 threads, level after level (a storage
// barrier between them), dispatched as (1, 1, 1): on a CPU adapter each dispatch of a
// few texels cost about as much as the big levels' (0.05-0.08 ms each).
$$ set tail = last_level is defined and last_level > level
$$ if tail
@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) lid: u32) {
    $$ for k in range(level, last_level + 1)
    {
        let src = s_hzb_levels[{{ k }}u];       // level {{ k - 1 }} (entry 0 is the header)
        let dst = s_hzb_levels[{{ k }}u + 1u];
        for (var t = lid; t < dst.y * dst.z; t += 64u) {
            let gx = t % dst.y;
            let gy = t / dst.y;
            let x0 = 2u * gx;
            let y0 = 2u * gy;
            let x1 = min(x0 + 1u, src.y - 1u);
            let y1 = min(y0 + 1u, src.z - 1u);
            let a = max(s_hzb[src.x + y0 * src.w + x0], s_hzb[src.x + y0 * src.w + x1]);
            let b = max(s_hzb[src.x + y1 * src.w + x0], s_hzb[src.x + y1 * src.w + x1]);
            s_hzb[dst.x + gy * dst.w + gx] = max(a, b);
        }
    }
    storageBarrier();
    workgroupBarrier();
    $$ endfor
}
$$ else
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
$$ endif
