// Per-frame culling and level-of-detail binning, before drawing.
// Survivors are appended to the compacted list of their LOD class
// (s_visible[class * n_blades + slot]) with one global atomicAdd per workgroup
// and class; the instance counts in s_args feed draw_indirect.
//
// Draw order (template variable bands > 0; the kernel engine): with LOD on, each
// class's list runs through `bands` log-spaced bands of the distance to the
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
// culled blades are appended too, to s_culled as id | reason << 30 (reason 1
// orientation, 2 frustum, 3 distance: the first test that culled the blade),
// counted in s_culled_args: one more indirect draw, flat coloured.
//
// Engine-neutral body: the engine declares (before this file) u_stdinfo
// (projection_transform, cam_transform, cam_transform_inv, physical_size),
// u_wobject (world_transform), u_cull (fields of grasswidget.gpu.field.CULL_UNIFORM),
// s_blades (array<vec4<f32>>, read), s_args (array<atomic<u32>>), s_visible
// (array<u32>); with teaching_views also u_cull's color_by and frozen_* fields,
// s_culled (array<u32>) and s_culled_args (array<atomic<u32>>); see
// grasswidget.core.shader_files.

{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}

const N_CLASSES: u32 = {{ n_classes }}u;
$$ set n_bands = bands if bands else 1
const BANDS: u32 = {{ n_bands }}u;
const KEYS: u32 = N_CLASSES * BANDS;
// One counter per key (LOD class, distance band), then one for the culled blades (color_by "cull").
const CULLED: u32 = KEYS;
var<workgroup> wg_count: array<atomic<u32>, {{ n_classes * n_bands + 1 }}>;
var<workgroup> wg_base: array<u32, {{ n_classes * n_bands + 1 }}>;

$$ if bands
// Distance band, 0 = nearest: log-spaced between band_near and band_far metres.
fn distance_band(v0: vec3<f32>, cam_pos: vec3<f32>) -> u32 {
    let d = max(length(v0 - cam_pos), {{ band_near }});
    let b = f32(BANDS) * log2(d / {{ band_near }}) / log2({{ band_far }} / {{ band_near }});
    return u32(clamp(b, 0.0, f32(BANDS - 1u)));
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
    for (var k = lid; k <= KEYS; k += {{ workgroup_size }}u) { atomicStore(&wg_count[k], 0u); }
    workgroupBarrier();

    let n = u_cull.n_blades;
    let i = (wid.y * nwg.x + wid.x) * {{ workgroup_size }}u + lid;
    let valid = i < n;
    var visible = false;
    var listed = false;  // appended to a list (visible, or culled with color_by "cull")
    var cls = 0u;
    var key = 0u;
    var reason = 0u;
    var slot = 0u;
    if (valid) {
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
        visible = reason == 0u;
        if (u_cull.lod != 0) {
            cls = lod_class_of(projected_pixels(v0, v2, h, view_proj, viewport_height));
        }
        key = cls * BANDS;
        $$ if bands
        if (u_cull.lod != 0) {
            key += distance_band(v0, cam_pos);  // LOD: nearest band first
        }
        $$ endif
        if (!visible) {
            cls = CULLED;
            key = CULLED;
        }
        listed = visible;
        $$ if teaching_views
        listed = visible || u_cull.color_by == {{ color_by_cull }};
        $$ endif
        if (listed) {
            slot = atomicAdd(&wg_count[key], 1u);
        }
    }
    workgroupBarrier();
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
    $$ if not (bands and phase == "count")
    workgroupBarrier();
    if (visible) {
        s_visible[cls * n + wg_base[key] + slot] = i;
    }
    $$ endif
    $$ if teaching_views and not (bands and phase == "count")
    if (listed && !visible) {
        s_culled[wg_base[CULLED] + slot] = i | (reason << 30u);
    }
    $$ endif
}
