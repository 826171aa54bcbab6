// Per-frame culling and level-of-detail binning, before drawing.
// Survivors are appended to the compacted list of their LOD class
// (s_visible[class * n_blades + slot]) with one global atomicAdd per workgroup
// and class; the instance counts in s_args feed draw_indirect.
//
// Draw order (template variable bands > 0; both engines' first phase): whatever
// the switches (LOD, culling tests on or off), each class's list runs through `bands` log-spaced bands of the distance to the
// camera, nearest first, so the draws go roughly front to back and the depth
// test rejects hidden fragments before they are written (on a CPU adapter most
// of the near overdraw's cost). The pass then runs twice (template variable
// phase): "count" counts survivors per key = class * BANDS + band into s_bands;
// prefix_bands.wgsl turns the counts into each band's first slot and the
// instance counts in s_args; "scatter" writes the ids (and the culled list).
// The engine then declares s_bands (array<atomic<u32>>: KEYS counts, KEYS cursors).
// The twin of reference.cull_reason() and reference.lod_class().
//
// Teaching views (template variable teaching_views, on in the kernel engine):
// the culling camera is the rendering camera (u_stdinfo), or a frozen copy of
// one (u_cull.frozen != 0: GrassField.freeze_culling). With color_by "cull",
// culled blades are appended too, to s_culled as id | reason << 29 (reason 1
// orientation, 2 frustum, 3 distance, 4 occlusion: the first test that culled the blade),
// counted in s_culled_args: one more indirect draw, flat coloured.
//
// Occlusion culling (template variable occlusion; reference.occlusion_cull), in two
// phases so that a blade that shows is never culled, however the camera, the wind or
// a ball move: occlusion == 1 is the first phase's cull, which while
// u_cull.occlusion_phase == 1 keeps only the blades seen last frame (bit i of
// s_occlusion_flags); the engine draws them, copies the depth buffer into the
// max-depth pyramid (hzb_build.wgsl), and runs occlusion == 2: every blade that
// passes the other tests is tested against that pyramid (occlusion.wgsl); the ones
// not hidden and not drawn in the first phase are listed from the end of their
// class's list (slot n - 1 - k; s_args is then the second phase's args, with the
// occluded count at s_args[4 * N_CLASSES]), and bit i of s_occlusion_flags becomes
// "passes every test now". Hidden ones are culled with reason 4. The pyramid holds
// depths drawn in this frame with this camera, so whatever it hides stays hidden.
// With the culling frozen the second phase tests nothing: the blades not seen when
// it froze are the occluded ones (the flags stop changing).
//
// Compute rasterization (template variable compute_raster; raster.wgsl): while
// u_cull.compute_raster != 0 and the render is u_cull.raster_width x raster_height
// pixels, a visible blade narrower on screen than u_cull.raster_max_px (full width at
// its middle, the render camera's pixels) is appended to s_raster instead of its LOD
// class's list (counted in s_raster_args[0]); the engine then declares s_raster
// (array<u32>) and s_raster_args (array<atomic<u32>>).
//
// Engine-neutral body: the engine declares (before this file) u_stdinfo
// (projection_transform, cam_transform, cam_transform_inv, physical_size),
// u_wobject (world_transform), u_cull (fields of grasswidget.gpu.field.CULL_UNIFORM),
// s_blades (array<vec4<f32>>, read), s_args (array<atomic<u32>>), s_visible
// (array<u32>); with teaching_views also u_cull's color_by and frozen_* fields,
// s_culled (array<u32>) and s_culled_args (array<atomic<u32>>); with occlusion also
// u_cull.occlusion_phase and s_occlusion_flags (array<u32>; read_write in phase 2),
// and in phase 2 s_hzb and s_hzb_levels (see occlusion.wgsl); see
// grasswidget.core.shader_files.

{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
$$ if occlusion == 2
{$ include 'grasswidget.occlusion.wgsl' $}
$$ endif

const N_CLASSES: u32 = {{ n_classes }}u;
$$ set n_bands = bands if bands else 1
const BANDS: u32 = {{ n_bands }}u;
const KEYS: u32 = N_CLASSES * BANDS;
// One counter per key (LOD class, distance band), then one for the culled blades (color_by "cull"),
// then one for the compute rasterizer's blades.
const CULLED: u32 = KEYS;
const RASTER: u32 = KEYS + 1u;
var<workgroup> wg_count: array<atomic<u32>, {{ n_classes * n_bands + 2 }}>;
var<workgroup> wg_base: array<u32, {{ n_classes * n_bands + 2 }}>;
$$ if occlusion
// Blade i was seen (passed every test) in the last frame with occlusion culling.
fn seen_last_frame(i: u32) -> bool {
    return ((s_occlusion_flags[i >> 5u] >> (i & 31u)) & 1u) != 0u;
}
$$ endif
$$ if occlusion == 2 and phase != "count"
const FLAG_WORDS: u32 = {{ workgroup_size // 32 }}u;
var<workgroup> wg_seen: array<atomic<u32>, {{ workgroup_size // 32 }}>;
var<workgroup> wg_occluded: atomic<u32>;
$$ endif

$$ if bands
// Distance band, 0 = nearest: log-spaced between band_near and band_far metres.
fn distance_band(v0: vec3<f32>, cam_pos: vec3<f32>) -> u32 {
    let d = max(length(v0 - cam_pos), {{ band_near }});
    let b = f32(BANDS) * log2(d / {{ band_near }}) / log2({{ band_far }} / {{ band_near }});
    return u32(clamp(b, 0.0, f32(BANDS - 1u)));
}
$$ endif

$$ if follow_camera
// Camera-following levels (a field to the horizon, core/horizon.py; template variable follow_camera,
// compiled in only for such a field): before its tests the pass moves blade i to the copy of its root
// nearest the culling camera on its level's tile (reference.follow_camera); v1 and v2 move with v0
// (its bend and motion are kept, and its collision strength, stored by id). A blade moves only where
// its weight is 0 (the bands end inside the tile's inscribed circle), so nothing visible jumps; the
// second run of a frame (count, then scatter) finds nothing to move. s_blades is read_write here.
{$ include 'grasswidget.levels.wgsl' $}
fn follow_camera(i: u32) {
    let k = blade_level(i);
    let period = u_cull.level_periods[k / 4u][k % 4u];
    let r0 = s_blades[4u * i + 0u];
    let shift = wrap_shift(r0.xz, levels_camera().xz, period);
    if (shift.x != 0.0 || shift.y != 0.0) {
        let d = vec4<f32>(shift.x, 0.0, shift.y, 0.0);
        s_blades[4u * i + 0u] = r0 + d;
        s_blades[4u * i + 1u] = s_blades[4u * i + 1u] + d;
        s_blades[4u * i + 2u] = s_blades[4u * i + 2u] + d;
    }
}
$$ endif

fn lod_class_of(pixels: f32) -> u32 {
    $$ for min_pixels in lod_min_pixels
    if (pixels >= {{ min_pixels }}) { return {{ loop.index0 }}u; }
    $$ endfor
    return N_CLASSES - 1u;
}

@compute @workgroup_size({{ workgroup_size }})
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    for (var k = lid; k <= RASTER; k += {{ workgroup_size }}u) { atomicStore(&wg_count[k], 0u); }
    $$ if occlusion == 2 and phase != "count"
    if (lid < FLAG_WORDS) { atomicStore(&wg_seen[lid], 0u); }
    if (lid == 0u) { atomicStore(&wg_occluded, 0u); }
    $$ endif
    workgroupBarrier();

    let n = u_cull.n_blades;
    let i = (wid.y * nwg.x + wid.x) * {{ workgroup_size }}u + lid;
    let valid = i < n;
    $$ if follow_camera
    if (valid) { follow_camera(i); }
    $$ endif
    var visible = false;
    var listed = false;  // appended to a list (visible, or culled with color_by "cull")
    var cls = 0u;
    var key = 0u;
    var reason = 0u;
    var slot = 0u;
    var frozen = false;
    var seen = false;  // passes every test, occlusion included (phase 2)
    var rastered = false;  // visible, drawn by the compute rasterizer
    $$ if occlusion == 1
    // Armed first phase: a blade not seen last frame is neither drawn nor listed now (the second
    // phase tests it), so its tests are skipped (most of a small culled view's blades, on a CPU).
    let deferred = u_cull.occlusion_phase == 1 && !seen_last_frame(min(i, n - 1u));
    if (valid && !deferred) {
    $$ else
    if (valid) {
    $$ endif
        let blade = load_blade(i);
        // To world space (blades live in the object's local space).
        let m = u_wobject.world_transform;
        let v0 = (m * vec4<f32>(blade.v0, 1.0)).xyz;
        let v1 = (m * vec4<f32>(blade.v1, 1.0)).xyz;
        let v2 = (m * vec4<f32>(blade.v2, 1.0)).xyz;
        let up = normalize((m * vec4<f32>(blade.up, 0.0)).xyz);
        let t1 = normalize((m * vec4<f32>(width_direction(blade.up, blade.orientation), 0.0)).xyz);
        var view_proj = u_stdinfo.projection_transform * u_stdinfo.cam_transform;
        var cam_pos = u_stdinfo.cam_transform_inv[3].xyz;
        var viewport_height = u_stdinfo.physical_size.y;
        $$ if teaching_views
        if (u_cull.frozen != 0) {
            frozen = true;
            view_proj = u_cull.frozen_view_proj;
            cam_pos = u_cull.frozen_cam_pos.xyz;
            viewport_height = u_cull.frozen_viewport_height;
        }
        $$ endif
        let scale = length(m[1].xyz);
        let h = blade.height * scale;

        // The first test that culls the blade is its reason (reference.cull_reason).
        if (u_cull.cull_orientation != 0 && orientation_cull(v0, t1, cam_pos, u_cull.orientation_threshold)) {
            reason = 1u;
        } else if (u_cull.cull_frustum != 0 && frustum_cull(v0, v1, v2, view_proj, u_cull.frustum_tolerance)) {
            reason = 2u;
        } else if (u_cull.cull_distance != 0 && distance_cull(v0, up, cam_pos, i, u32(u_cull.buckets), u_cull.distance_max)) {
            reason = 3u;
        }
        $$ if follow_camera
        let weight = blade_weight(i, blade.v0);  // 0: outside its level's band, culled with distance
        if (reason == 0u && weight <= 0.0) {
            reason = 3u;
        }
        let drawn_width = blade.width * weight;
        $$ else
        let drawn_width = blade.width;
        $$ endif
        visible = reason == 0u;
        $$ if occlusion == 1
        if (visible && u_cull.occlusion_phase == 1 && !seen_last_frame(i)) {
            visible = false;  // deferred to the second phase (not culled)
        }
        $$ elif occlusion == 2
        if (visible) {
            let drawn_first = seen_last_frame(i);
            var hidden = !drawn_first;  // frozen: the blades not seen when it froze
            if (!frozen) {
                let stretch = max(length(m[0].xyz), max(length(m[1].xyz), length(m[2].xyz)));
                let radius = {{ occlusion_radius_per_width }} * drawn_width * stretch;
                hidden = blade_occluded(v0, v1, v2, radius, view_proj, u_stdinfo.physical_size);
            }
            seen = !hidden;
            if (drawn_first) {
                visible = false;  // drawn in the first phase already (hidden now: not drawn first next frame)
            } else if (hidden) {
                reason = 4u;
                visible = false;
            }
        }
        $$ endif
        $$ if compute_raster
        let size = u_stdinfo.physical_size;
        if (visible && u_cull.compute_raster != 0 && size.x == u_cull.raster_width && size.y == u_cull.raster_height) {
            let render_view_proj = u_stdinfo.projection_transform * u_stdinfo.cam_transform;
            let across_px = projected_pixels(v0, v2, 2.0 * drawn_width * scale, render_view_proj, size.y);
            let in_front = min(min((render_view_proj * vec4<f32>(v0, 1.0)).w, (render_view_proj * vec4<f32>(v1, 1.0)).w),
                               (render_view_proj * vec4<f32>(v2, 1.0)).w) > 1e-6;
            rastered = in_front && across_px < u_cull.raster_max_px;
        }
        $$ endif
        if (u_cull.lod != 0) {
            cls = lod_class_of(projected_pixels(v0, v2, h, view_proj, viewport_height));
        }
        key = cls * BANDS;
        $$ if bands
        key += distance_band(v0, cam_pos);  // nearest band first, with or without LOD
        $$ endif
        if (!visible) {
            cls = CULLED;
            key = CULLED;
        }
        if (rastered) {
            key = RASTER;
        }
        listed = visible;
        $$ if teaching_views
        listed = visible || (u_cull.color_by == {{ color_by_cull }} && reason != 0u);
        $$ if occlusion == 1
        // While armed, the second phase lists the culled blades (with the occluded ones).
        listed = listed && (visible || u_cull.occlusion_phase != 1);
        $$ endif
        $$ endif
        if (listed) {
            slot = atomicAdd(&wg_count[key], 1u);
        }
        $$ if occlusion == 2 and phase != "count"
        if (seen) {
            atomicOr(&wg_seen[lid >> 5u], 1u << (lid & 31u));
        }
        if (reason == 4u) {
            atomicAdd(&wg_occluded, 1u);
        }
        $$ endif
    }
    workgroupBarrier();
    $$ if occlusion == 2 and phase != "count"
    let wg_index = wid.y * nwg.x + wid.x;
    if (lid < FLAG_WORDS && u_cull.frozen == 0) {
        s_occlusion_flags[wg_index * FLAG_WORDS + lid] = atomicLoad(&wg_seen[lid]);
    }
    if (lid == 0u) {
        let c = atomicLoad(&wg_occluded);
        if (c > 0u) {
            atomicAdd(&s_args[N_CLASSES * 4u], c);
        }
    }
    $$ endif
    for (var k = lid; k < KEYS; k += {{ workgroup_size }}u) {
        let c = atomicLoad(&wg_count[k]);
        if (c > 0u) {
            $$ if not bands
            wg_base[k] = atomicAdd(&s_args[k * 4u + 1u], c);
            $$ elif phase == "count"
            atomicAdd(&s_bands[k], c);
            $$ else
            wg_base[k] = atomicAdd(&s_bands[KEYS + k], c);
            $$ endif
        }
    }
    $$ if teaching_views and not (bands and phase == "count")
    if (lid == 0u) {  // one thread reserves the culled list's range
        let c = atomicLoad(&wg_count[CULLED]);
        if (c > 0u) {
            wg_base[CULLED] = atomicAdd(&s_culled_args[1], c);
        }
    }
    $$ endif
    $$ if compute_raster and not (bands and phase == "count")
    if (lid == 0u) {  // one thread reserves the compute rasterizer's range
        let c = atomicLoad(&wg_count[RASTER]);
        if (c > 0u) {
            wg_base[RASTER] = atomicAdd(&s_raster_args[0], c);
        }
    }
    $$ endif
    $$ if not (bands and phase == "count")
    workgroupBarrier();
    $$ if compute_raster
    if (rastered) {
        s_raster[wg_base[RASTER] + slot] = i;
    }
    $$ endif
    if (visible && !rastered) {
        $$ if occlusion == 2
        s_visible[cls * n + n - 1u - (wg_base[key] + slot)] = i;  // from the end: the second phase's list
        $$ else
        s_visible[cls * n + wg_base[key] + slot] = i;
        $$ endif
    }
    $$ endif
    $$ if teaching_views and not (bands and phase == "count")
    if (listed && !visible) {
        s_culled[wg_base[CULLED] + slot] = i | (reason << 29u);
    }
    $$ endif
}
