// The occlusion test of the culling's second phase (cull.wgsl with occlusion == 2):
// a blade is hidden when its nearest depth is farther than the farthest depth of
// the max-depth pyramid over its screen rect. The twin of reference.hzb_max() and
// reference.occlusion_cull().
//
// Engine-neutral: the engine declares s_hzb (array<f32>, the pyramid, read) and
// s_hzb_levels (array<vec4<u32>>: [0] = (levels, width, height, 0) of level 0, then
// per level (offset, width, height, pitch) in texels: reference.hzb_layout()).

// Farthest depth over the pixels floor(x0)..floor(x1) x floor(y0)..floor(y1), read at `level`.
fn hzb_max(rect: vec4<f32>, level: u32) -> f32 {
    let head = s_hzb_levels[0];
    let lv = min(level, head.x - 1u);
    let info = s_hzb_levels[lv + 1u];
    let tx0 = min(u32(rect.x), head.y - 1u) >> lv;
    let tx1 = min(u32(rect.z), head.y - 1u) >> lv;
    let ty0 = min(u32(rect.y), head.z - 1u) >> lv;
    let ty1 = min(u32(rect.w), head.z - 1u) >> lv;
    var far = 0.0;
    for (var ty = ty0; ty <= ty1; ty += 1u) {
        for (var tx = tx0; tx <= tx1; tx += 1u) {
            far = max(far, s_hzb[info.x + ty * info.w + tx]);
        }
    }
    return far;
}

// Hidden: every pixel the blade could cover already holds something nearer.
fn occluded(b: ScreenBounds) -> bool {
    return b.depth > hzb_max(b.rect, hzb_level(b.rect));
}
