// Per-frame culling and level-of-detail binning, before drawing.
// Survivors go to the compacted list of their LOD class (s_visible[class *
// n_blades + slot]). With LOD on, nearest first: within a class, blades are
// ordered by distance band (BANDS log-spaced bands of the distance to the
// camera), so the draws run roughly front to back and the depth test rejects
// hidden fragments before they are written (on a CPU adapter most of the near
// overdraw's cost). With LOD off there is one list, in blade-id order.
// It runs twice per frame (PHASE): "count" counts survivors per (class, band);
// prefix_bands.wgsl turns the counts into each band's first slot and the
// instance counts in s_args (they feed draw_indirect); "scatter" writes the ids.
// Each phase aggregates per workgroup: one global atomicAdd per workgroup and key.
// The twin of reference.cull() and reference.lod_class().

{{ bindings_code }}
{$ include 'grasswidget.blade_math.wgsl' $}

@group(0) @binding(10) var<storage, read> s_blades: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> s_args: array<atomic<u32>>;
@group(0) @binding(12) var<storage, read_write> s_visible: array<u32>;
// [0, KEYS): survivors per key = class * BANDS + band; [KEYS, 2 KEYS): next free slot per key.
@group(0) @binding(13) var<storage, read_write> s_bands: array<atomic<u32>>;

const N_CLASSES: u32 = {{ n_classes }}u;
const BANDS: u32 = {{ bands }}u;
const KEYS: u32 = N_CLASSES * BANDS;
var<workgroup> wg_count: array<atomic<u32>, {{ n_classes * bands }}>;
var<workgroup> wg_base: array<u32, {{ n_classes * bands }}>;

// Distance band, 0 = nearest: log-spaced between BAND_NEAR and BAND_FAR metres.
fn distance_band(v0: vec3<f32>, cam_pos: vec3<f32>) -> u32 {
    let d = max(length(v0 - cam_pos), {{ band_near }});
    let b = f32(BANDS) * log2(d / {{ band_near }}) / log2({{ band_far }} / {{ band_near }});
    return u32(clamp(b, 0.0, f32(BANDS - 1u)));
}

fn lod_class_of(pixels: f32) -> u32 {
    $$ for min_pixels in lod_min_pixels
    if (pixels >= {{ min_pixels }}) { return {{ loop.index0 }}u; }
    $$ endfor
    return N_CLASSES - 1u;
}

@compute @workgroup_size(256)
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    for (var k = lid; k < KEYS; k += 256u) { atomicStore(&wg_count[k], 0u); }
    workgroupBarrier();

    let n = u_cull.n_blades;
    let i = (wid.y * nwg.x + wid.x) * 256u + lid;
    var visible = i < n;
    var cls = 0u;
    var key = 0u;
    var slot = 0u;
    if (visible) {
        let p0 = s_blades[4u * i + 0u];
        let p1 = s_blades[4u * i + 1u];
        let p2 = s_blades[4u * i + 2u];
        let p3 = s_blades[4u * i + 3u];
        // To world space (blades live in the object's local space).
        let m = u_wobject.world_transform;
        let v0 = (m * vec4<f32>(p0.xyz, 1.0)).xyz;
        let v1 = (m * vec4<f32>(p1.xyz, 1.0)).xyz;
        let v2 = (m * vec4<f32>(p2.xyz, 1.0)).xyz;
        let up = normalize((m * vec4<f32>(p3.xyz, 0.0)).xyz);
        let t1 = normalize((m * vec4<f32>(width_direction(p3.xyz, p0.w), 0.0)).xyz);
        let view_proj = u_stdinfo.projection_transform * u_stdinfo.cam_transform;
        let cam_pos = u_stdinfo.cam_transform_inv[3].xyz;
        let scale = length(m[1].xyz);
        let h = p1.w * scale;

        if (u_cull.cull_orientation != 0 && orientation_cull(v0, t1, cam_pos, u_cull.orientation_threshold)) {
            visible = false;
        }
        if (u_cull.cull_frustum != 0 && frustum_cull(v0, v1, v2, view_proj, u_cull.frustum_tolerance)) {
            visible = false;
        }
        if (u_cull.cull_distance != 0 && distance_cull(v0, up, cam_pos, i, u32(u_cull.buckets), u_cull.distance_max)) {
            visible = false;
        }
        if (u_cull.lod != 0) {
            cls = lod_class_of(projected_pixels(v0, v2, h, view_proj, u_stdinfo.physical_size.y));
        }
        if (u_cull.lod != 0) {
            key = cls * BANDS + distance_band(v0, cam_pos);  // LOD draws each class nearest band first
        } else {
            key = cls * BANDS;  // no LOD: one list in blade-id order
        }
        if (visible) {
            slot = atomicAdd(&wg_count[key], 1u);
        }
    }
    workgroupBarrier();
    for (var k = lid; k < KEYS; k += 256u) {
        let c = atomicLoad(&wg_count[k]);
        if (c > 0u) {
            $$ if phase == "count"
            atomicAdd(&s_bands[k], c);
            $$ else
            wg_base[k] = atomicAdd(&s_bands[KEYS + k], c);
            $$ endif
        }
    }
    $$ if phase == "scatter"
    workgroupBarrier();
    if (visible) {
        s_visible[cls * n + wg_base[key] + slot] = i;
    }
    $$ endif
}
