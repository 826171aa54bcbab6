// Reset the indirect draw arguments at the start of every frame's compute pass:
// one draw per level-of-detail class, (vertex_count, instance_count = 0, 0, 0),
// and the draw of the culled blades (color_by "cull"); with occlusion the second
// occlusion phase's args too.

@group(0) @binding(0) var<storage, read_write> s_args: array<u32>;
$$ if teaching_views
@group(0) @binding(1) var<storage, read_write> s_culled_args: array<u32>;
$$ endif
$$ if bands
// The culling's distance-band counters and cursors (see cull.wgsl).
@group(0) @binding(2) var<storage, read_write> s_bands: array<u32>;
$$ endif

$$ if occlusion
// The second occlusion phase's draw args (one record per class) and its occluded count.
@group(0) @binding(3) var<storage, read_write> s_occlusion_args: array<u32>;
$$ endif

@compute @workgroup_size(1)
fn main() {
    $$ for segments in lod_segments
    s_args[{{ loop.index0 }}u * 4u + 0u] = {{ 2 * (segments + 1) }}u;
    s_args[{{ loop.index0 }}u * 4u + 1u] = 0u;
    s_args[{{ loop.index0 }}u * 4u + 2u] = 0u;
    s_args[{{ loop.index0 }}u * 4u + 3u] = 0u;
    $$ endfor
    $$ if teaching_views
    s_culled_args[0] = {{ 2 * (culled_segments + 1) }}u;
    s_culled_args[1] = 0u;
    s_culled_args[2] = 0u;
    s_culled_args[3] = 0u;
    $$ endif
    $$ if occlusion
    $$ for segments in lod_segments
    s_occlusion_args[{{ loop.index0 }}u * 4u + 0u] = {{ 2 * (segments + 1) }}u;
    s_occlusion_args[{{ loop.index0 }}u * 4u + 1u] = 0u;
    s_occlusion_args[{{ loop.index0 }}u * 4u + 2u] = 0u;
    s_occlusion_args[{{ loop.index0 }}u * 4u + 3u] = 0u;
    $$ endfor
    s_occlusion_args[{{ n_classes }}u * 4u] = 0u;
    $$ endif
    $$ if bands
    for (var k = 0u; k < arrayLength(&s_bands); k += 1u) {
        s_bands[k] = 0u;
    }
    $$ endif
}
