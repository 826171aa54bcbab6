// The compute rasterizer of thin blades (GrassParams.compute_raster): one thread per
// blade of the list cull.wgsl wrote (s_raster, count s_raster_args[0]) walks its curve
// on screen with its tapered width and depth-tests each pixel with atomics into
// per-pixel words of u_cull.raster_width x raster_height. Two layouts, chosen by Python
// (template variable raster_packed; gpu/raster_walks.py):
//
// * one walk (raster_packed, where the device has 64-bit atomic min/max: lavapipe, most
//   Vulkan GPUs): s_raster_depth holds a u64 per pixel, the depth's float bits in the high
//   word and the bitwise complement of the payload in the low word; the walk (step
//   "packed") writes atomicMin of that pair: the nearest depth wins, equal depths the
//   larger payload, in one pass. Read as u32 words: 2 i + 1 the depth, ~(2 i) the payload.
// * two walks (the browser engine, WebGPU has no 64-bit atomics): s_raster_depth and
//   s_raster_payload a u32 per pixel each; step "depth" writes atomicMin of the depth's
//   float bits (0 < depth <= 1: the bits of a positive float order like the float), step
//   "payload" walks again and, where the pixel's depth word is this blade's depth,
//   atomicMax of raster_payload(blade, v) (the same winner as the one walk).
//
// step "clear_args": one thread at the start of the frame (before the culling): the list
//   counters to 0, and the clear's workgroups into s_raster_dispatch[4..6] for the pixels
//   of the rows the last frame's walks wrote (s_raster_args[2] .. ~s_raster_args[3], see
//   "args"; none written: no workgroup). Counters that are all zero (a new buffer) mean
//   every row: a new pixel buffer is cleared whole.
// step "clear" (dispatched indirectly from those workgroups): thread i empties pixel
//   first_row * width + i of those rows (depth RASTER_EMPTY, payload 0; packed: both words
//   all ones). A view where no blade was walked pays for no pixel.
// step "args": one thread, after the culling and before the walks: the walks' workgroups
//   (x, y, 1) into s_raster_dispatch (the walks are dispatched indirectly, so only the
//   listed blades run: a thread per blade of the whole field cost a CPU adapter as much
//   as the walks themselves); first phase: where its part of the list ends into
//   s_raster_args[1] and the written rows to none (s_raster_args[2] = [3] = 0xffffffff).
// The walk ("packed", or "depth" then "payload"), per listed blade: the blade is
//   projected once (its control points and half-width vector), then sampled about 0.9
//   pixels apart along its curve on screen (raster_step); at each sample the tapered
//   cross-section (raster_section: one divide) is covered by raster_cover points one
//   multiply-add apart. The walk that writes depth ("packed" or "depth") then widens
//   the written rows to its own (atomicMin of the first row into s_raster_args[2], of
//   the bitwise complement of the last into [3]).
// A resolve pass (raster_resolve.wgsl) then shades each covered pixel with the
// ribbons' shading (blade_shade) and writes its depth, so everything else in the
// scene composites with the ordinary depth test; it draws only the written rows, and
// the next frame's clear touches only those rows (on a CPU adapter a full-screen pass
// costs per pixel, while the thin blades are far away, near the horizon).
//
// Occlusion culling's second phase (template variable second) appends its blades to
// the same list: the first phase's args step records where its part ends
// (s_raster_args[1]) and the second phase's steps walk only the rest.
//
// The per-blade walk is reference.raster_walk (its NumPy twin), built from the
// blade_math functions raster_step, raster_section, raster_cover, raster_payload;
// tests/gpu/test_compute_raster.py checks the rows written against the words read back.
//
// Engine-neutral body: the engine declares (before this file) u_stdinfo
// (projection_transform, cam_transform, physical_size), u_wobject (world_transform),
// u_cull (CULL_LAYOUT: raster_width, raster_height, raster_blade_shape,
// raster_tip_threshold), s_blades (array<vec4<f32>>, read), s_raster (array<u32>, read),
// s_raster_args (array<atomic<u32>>), s_raster_depth (array<atomic<u64>> in step "packed",
// else array<atomic<u32>>) and, unless packed, s_raster_payload (array<atomic<u32>>), and
// for the args and clear_args steps s_raster_dispatch (array<u32>, 8 words: the walks'
// workgroups at 0, the clear's at 4).

{$ include 'grasswidget.blade.wgsl' $}
{$ include 'grasswidget.blade_math.wgsl' $}
$$ if follow_camera
{$ include 'grasswidget.levels.wgsl' $}
$$ endif
$$ if step == "shade"
{$ include 'grasswidget.shadows.wgsl' $}
$$ if teaching_views
const RASTER_COLOR = vec3<f32>({{ raster_color }});
$$ endif
$$ endif

const RASTER_EMPTY: u32 = 0xffffffffu;

$$ if step == "depth" or step == "payload" or step == "packed"
fn raster_blade(blade_id: u32) {
    let rec = load_blade(blade_id);
    let mvp = u_stdinfo.projection_transform * u_stdinfo.cam_transform * u_wobject.world_transform;
    let c0 = mvp * vec4<f32>(rec.v0, 1.0);
    let c1 = mvp * vec4<f32>(rec.v1, 1.0);
    let c2 = mvp * vec4<f32>(rec.v2, 1.0);
    $$ if follow_camera
    let drawn_width = rec.width * blade_weight(blade_id, rec.v0);  // a field to the horizon (levels.wgsl)
    $$ else
    let drawn_width = rec.width;
    $$ endif
    let across = mvp * vec4<f32>(drawn_width * width_direction(rec.up, rec.orientation), 0.0);
    let size = vec2<f32>(u_cull.raster_width, u_cull.raster_height);
    let width = u32(size.x);
    let across_px = across.xy * vec2<f32>(0.5 * size.x, -0.5 * size.y);
    let s0 = clip_to_pixel(c0, size).xy;
    let s1 = clip_to_pixel(c1, size).xy;
    let s2 = clip_to_pixel(c2, size).xy;
    let shape = u_cull.raster_blade_shape;
    let tau = u_cull.raster_tip_threshold;
    var v = 0.0;
    $$ if step != "payload"
    var first_row = RASTER_EMPTY;
    var last_row = 0u;
    $$ endif
    for (var s = 0u; s <= u32({{ raster_max_samples }}); s += 1u) {
        let span = raster_section(c0, c1, c2, across_px, v, shape, tau, size);
        let m = raster_cover(blade_id, s, length(span.b.xy - span.a.xy));
        let along = (span.b.xy - span.a.xy) / f32(max(m, 1u));
        let depth = bitcast<u32>(span.a.z);  // one depth across the section
        if (m > 0u && span.a.z > 0.0 && span.a.z <= 1.0) {
            $$ if step == "payload"
            let payload = raster_payload(blade_id, v);
            $$ elif step == "packed"
            let key = (u64(depth) << 32u) | u64(~raster_payload(blade_id, v));
            $$ endif
            for (var j = 0u; j < m; j += 1u) {
                let px = floor(span.a.xy + (f32(j) + 0.5) * along);
                if (px.x < 0.0 || px.y < 0.0 || px.x >= size.x || px.y >= size.y) {
                    continue;
                }
                let index = u32(px.y) * width + u32(px.x);
                $$ if step == "packed"
                atomicMin(&s_raster_depth[index], key);
                $$ elif step == "depth"
                atomicMin(&s_raster_depth[index], depth);
                $$ else
                if (atomicLoad(&s_raster_depth[index]) == depth) {
                    atomicMax(&s_raster_payload[index], payload);
                }
                $$ endif
                $$ if step != "payload"
                first_row = min(first_row, u32(px.y));
                last_row = max(last_row, u32(px.y));
                $$ endif
            }
        }
        if (v >= 1.0) {
            break;
        }
        v = min(v + raster_step(s0, s1, s2, v), 1.0);
    }
    $$ if step != "payload"
    if (first_row <= last_row) {
        atomicMin(&s_raster_args[2], first_row);
        atomicMin(&s_raster_args[3], ~last_row);
    }
    $$ endif
}
$$ endif

$$ if step == "shade"
// The colour of pixel `pixel` of the written rows (nothing where no blade won it): the winning
// blade's curve point v shaded like the ribbons shade it (blade_math.blade_shade with the ribbon's
// normal, the looks' base colour, glow, sunlight and fog), as two f16 pairs (r, g), (b, 0) into
// s_raster_color; the resolve (raster_resolve.wgsl) writes it with the pixel's depth.
fn raster_shade_pixel(pixel: u32) {
    $$ if raster_packed
    let depth = atomicLoad(&s_raster_depth[2u * pixel + 1u]);
    let payload = ~atomicLoad(&s_raster_depth[2u * pixel]);
    $$ else
    let depth = atomicLoad(&s_raster_depth[pixel]);
    let payload = atomicLoad(&s_raster_payload[pixel]);
    $$ endif
    if (depth == RASTER_EMPTY) {
        return;
    }
    let blade = payload >> 8u;
    let v = f32(payload & 255u) / 255.0;
    let rec = load_blade(blade);
    // The ribbon's curve point, tangent and normal at v (blade_render.wgsl).
    let a = rec.v0 + v * (rec.v1 - rec.v0);
    let b = rec.v1 + v * (rec.v2 - rec.v1);
    let c = a + v * (b - a);
    let t1 = width_direction(rec.up, rec.orientation);
    var t0 = b - a;
    if (dot(t0, t0) < 1e-12) { t0 = rec.up; }
    let n = cross(normalize(t0), t1);
    let world_pos = (u_wobject.world_transform * vec4<f32>(c, 1.0)).xyz;
    let world_normal = (u_wobject.world_transform * vec4<f32>(n, 0.0)).xyz;
    let cam_pos = u_stdinfo.cam_transform_inv[3].xyz;
    // The blade's colour like the ribbons' vertices give it (blade_render.wgsl): its
    // patch (clump noise of the root), its hash, the glow against the sun and the fog.
    let eye = cam_pos - world_pos;
    let clump = clump_noise(rec.v0.x, rec.v0.z, u_material.patch_size);
    let base = blade_base_color(u_material.root_color.rgb, u_material.tip_color.rgb, v, hash01(blade), clump,
                                u_material.color_variation, u_material.dryness);
    let glow = backlight(normalize(eye), normalize(u_material.light_direction.xyz), v, u_material.translucency);
    let fog = fog_amount(length(eye), u_material.fog_density);
    let sunlit = blade_sunlight(world_pos, v, u_material.ambient);  // shadows.wgsl, as the ribbons
    var rgb = blade_shade(world_normal, normalize(eye), v, base * sunlit.x, glow * sunlit.y, fog, u_material.fog_color.rgb,
                          u_material.light_direction.xyz, u_material.ambient);
    $$ if teaching_views
    if (u_cull.color_by == {{ color_by_lod }}) { rgb = RASTER_COLOR; }
    $$ endif
    s_raster_color[2u * pixel] = pack2x16float(rgb.rg);
    s_raster_color[2u * pixel + 1u] = pack2x16float(vec2<f32>(rgb.b, 0.0));
}
$$ endif

$$ if step == "clear_args" or step == "shade_args"
// A thread per pixel of the written rows (s_raster_args[2] .. ~s_raster_args[3], clamped to the view):
// their workgroups (x, y, 1), folded into y past max_groups_x, into s_raster_dispatch[at .. at + 2];
// none when no row was written.
fn rows_dispatch(at: u32) {
    let width = u32(u_cull.raster_width);
    let height = u32(u_cull.raster_height);
    let first_row = atomicLoad(&s_raster_args[2]);
    let last_row = min(~atomicLoad(&s_raster_args[3]), height - 1u);
    let pixels = select(0u, (last_row - first_row + 1u) * width, height > 0u && first_row <= last_row);
    let groups = (pixels + {{ workgroup_size }}u - 1u) / {{ workgroup_size }}u;
    let x = min(groups, {{ max_groups_x }}u);
    s_raster_dispatch[at] = x;
    s_raster_dispatch[at + 1u] = select(0u, (groups + x - 1u) / max(x, 1u), x > 0u);
    s_raster_dispatch[at + 2u] = 1u;
}
$$ endif

@compute @workgroup_size({{ workgroup_size }})
fn main(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.y * nwg.x + wid.x) * {{ workgroup_size }}u + lid;
    $$ if step == "clear_args"
    if (i == 0u) {
        atomicStore(&s_raster_args[0], 0u);
        atomicStore(&s_raster_args[1], 0u);
        rows_dispatch(4u);  // the clear's: the rows the last frame wrote (counters all zero: every row)
    }
    $$ elif step == "clear"
    let width = u32(u_cull.raster_width);
    let first = atomicLoad(&s_raster_args[2]) * width;  // the first row written, from its start
    let last_row = min(~atomicLoad(&s_raster_args[3]), u32(u_cull.raster_height) - 1u);
    let pixel = first + i;
    if (pixel < (last_row + 1u) * width) {
        $$ if raster_packed
        atomicStore(&s_raster_depth[2u * pixel], RASTER_EMPTY);
        atomicStore(&s_raster_depth[2u * pixel + 1u], RASTER_EMPTY);
        $$ else
        atomicStore(&s_raster_depth[pixel], RASTER_EMPTY);
        atomicStore(&s_raster_payload[pixel], 0u);
        $$ endif
    }
    $$ elif step == "args"
    if (i == 0u) {
        let end = atomicLoad(&s_raster_args[0]);
        $$ if second
        let first = atomicLoad(&s_raster_args[1]);
        $$ else
        let first = 0u;
        atomicStore(&s_raster_args[1], end);  // where the second occlusion phase's blades start
        atomicStore(&s_raster_args[2], RASTER_EMPTY);  // no row written yet
        atomicStore(&s_raster_args[3], RASTER_EMPTY);
        $$ endif
        let groups = (end - first + {{ workgroup_size }}u - 1u) / {{ workgroup_size }}u;
        let x = min(groups, {{ max_groups_x }}u);
        s_raster_dispatch[0] = x;
        s_raster_dispatch[1] = select(0u, (groups + x - 1u) / max(x, 1u), x > 0u);
        s_raster_dispatch[2] = 1u;
    }
    $$ elif step == "shade_args"
    if (i == 0u) {
        rows_dispatch(8u);  // the shade's: the rows this frame's walks wrote (none: first > last)
    }
    $$ elif step == "shade"
    let width = u32(u_cull.raster_width);
    let first_row = atomicLoad(&s_raster_args[2]);
    let last_row = min(~atomicLoad(&s_raster_args[3]), u32(u_cull.raster_height) - 1u);
    let pixel = first_row * width + i;
    if (first_row <= last_row && pixel < (last_row + 1u) * width) {
        raster_shade_pixel(pixel);
    }
    $$ else
    let end = atomicLoad(&s_raster_args[0]);
    $$ if second
    let first = atomicLoad(&s_raster_args[1]);
    $$ else
    let first = 0u;
    $$ endif
    if (first + i < end) {
        raster_blade(s_raster[first + i]);
    }
    $$ endif
}
