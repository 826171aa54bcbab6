// The occlusion test of the culling's second phase (cull.wgsl with occlusion == 2):
// a blade is hidden when, for each piece of its curve, the piece's nearest depth is
// farther than the farthest depth of the max-depth pyramid over its screen rect. The twin of reference.hzb_max() and
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

// Hidden: every pixel the blade could cover already holds something nearer. The curve
// is split into {{ occlusion_pieces }} pieces of equal t, each boxed by its own control
// points (reference.curve_pieces); the blade is hidden when every piece is.
fn blade_occluded(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, radius: f32, view_proj: mat4x4<f32>, viewport_size: vec2<f32>) -> bool {
    let n = f32({{ occlusion_pieces }});
    for (var k = 0u; k < {{ occlusion_pieces }}u; k += 1u) {
        let a = f32(k) / n;
        let b = f32(k + 1u) / n;
        let p0 = (1.0 - a) * (1.0 - a) * v0 + 2.0 * a * (1.0 - a) * v1 + a * a * v2;
        let p1 = (1.0 - a) * (1.0 - b) * v0 + (a * (1.0 - b) + b * (1.0 - a)) * v1 + a * b * v2;
        let p2 = (1.0 - b) * (1.0 - b) * v0 + 2.0 * b * (1.0 - b) * v1 + b * b * v2;
        let bounds = occlusion_bounds(p0, p1, p2, radius, view_proj, viewport_size);
        if (bounds.depth <= hzb_max(bounds.rect, hzb_level(bounds.rect))) {
            return false;
        }
    }
    return true;
}
