// The browser engine's overlay lines and points, drawn over the meadow: the frozen
// culling camera's view volume and the blade inspector's control polygon, force
// arrows and control points (the kernel engine draws them with pygfx's Line and
// Points). The positions are a buffer of 3 floats per vertex (NaN: not drawn),
// written by Python (the frustum, grasswidget.core.teaching.frustum_segments) or by
// inspect.wgsl on the GPU. Every item is a screen-space quad (two triangles) of
// SIZE_PX physical pixels across; colours repeat every PERIOD vertices.
// grasswidget.browser.browser_wgsl.BrowserShaders.overlay renders this template (primitive,
// size_px, colours) and prepends StdInfo.

@group(0) @binding(0) var<uniform> u_stdinfo: StdInfo;
@group(0) @binding(1) var<storage, read> s_overlay: array<f32>;

struct OverlayOut {
    @builtin(position) position: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) corner: vec2<f32>,
};

const SIZE_PX: f32 = {{ size_px }};
const PERIOD: u32 = {{ period }}u;
// Clip-space w below which a point is behind the eye (lines are cut there).
const NEAR_W: f32 = 1e-5;

fn overlay_position(k: u32) -> vec3<f32> {
    return vec3<f32>(s_overlay[3u * k], s_overlay[3u * k + 1u], s_overlay[3u * k + 2u]);
}

// NaN by its bits (a compiler may assume a float never compares unequal to itself).
fn not_drawn(p: vec3<f32>) -> bool {
    let bits = bitcast<vec3<u32>>(p) & vec3<u32>(0x7fffffffu);
    return any(bits > vec3<u32>(0x7f800000u));
}

fn to_clip(p: vec3<f32>) -> vec4<f32> {
    return u_stdinfo.projection_transform * u_stdinfo.cam_transform * vec4<f32>(p, 1.0);
}

fn vertex_color(k: u32) -> vec4<f32> {
    var colors = array<vec4<f32>, {{ period }}>({{ colors }});
    return colors[k % PERIOD];
}

// Corner of the quad: 0 (a, -), 1 (a, +), 2 (b, -), 3 (b, -), 4 (a, +), 5 (b, +).
fn far_end(corner: u32) -> bool {
    return corner == 2u || corner == 3u || corner == 5u;
}

fn plus_side(corner: u32) -> bool {
    return corner == 1u || corner == 4u || corner == 5u;
}

@vertex
fn vs_main(@builtin(vertex_index) corner: u32, @builtin(instance_index) item: u32) -> OverlayOut {
    var out: OverlayOut;
    out.position = vec4<f32>(0.0, 0.0, 0.0, 1.0);  // all corners equal: nothing drawn
    out.color = vec4<f32>(0.0);
    out.corner = vec2<f32>(0.0);
    let half_px = 0.5 * u_stdinfo.physical_size;
$$ if primitive == "segments"
    let ka = 2u * item;
    let pa = overlay_position(ka);
    let pb = overlay_position(ka + 1u);
    if (not_drawn(pa) || not_drawn(pb)) { return out; }
    var a = to_clip(pa);
    var b = to_clip(pb);
    if (a.w < NEAR_W && b.w < NEAR_W) { return out; }
    if (a.w < NEAR_W) { a = mix(a, b, (NEAR_W - a.w) / (b.w - a.w)); }
    if (b.w < NEAR_W) { b = mix(b, a, (NEAR_W - b.w) / (a.w - b.w)); }
    var d = (b.xy / b.w - a.xy / a.w) * half_px;
    if (length(d) < 1e-6) { d = vec2<f32>(1.0, 0.0); }
    let normal_px = normalize(vec2<f32>(-d.y, d.x)) * (0.5 * SIZE_PX);
    let end = select(a, b, far_end(corner));
    let side = select(-1.0, 1.0, plus_side(corner));
    out.position = vec4<f32>(end.xy + side * normal_px / half_px * end.w, end.z, end.w);
    out.color = vertex_color(select(ka, ka + 1u, far_end(corner)));
$$ else
    let p = overlay_position(item);
    if (not_drawn(p)) { return out; }
    let c = to_clip(p);
    if (c.w < NEAR_W) { return out; }
    let uv = vec2<f32>(select(-1.0, 1.0, far_end(corner)), select(-1.0, 1.0, plus_side(corner)));
    out.position = vec4<f32>(c.xy + uv * (0.5 * SIZE_PX) / half_px * c.w, c.z, c.w);
    out.color = vertex_color(item);
    out.corner = uv;
$$ endif
    return out;
}

@fragment
fn fs_main(frag: OverlayOut) -> @location(0) vec4<f32> {
$$ if primitive == "points"
    if (dot(frag.corner, frag.corner) > 1.0) { discard; }  // round dots
$$ endif
    return vec4<f32>(frag.color.rgb, 1.0);
}
