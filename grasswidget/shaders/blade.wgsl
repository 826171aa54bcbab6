// The blade record: 4 x vec4<f32> = 64 bytes per blade in `s_blades`, the twin
// of grasswidget.core.blades.BLADE_LAYOUT / pack_state / unpack_state:
//   row 0: v0.xyz root (m),        w orientation theta (rad)
//   row 1: v1.xyz guide (m),       w height h (m)
//   row 2: v2.xyz tip guide (m),   w width w (m)
//   row 3: up.xyz unit normal,     w stiffness s (1/s)
// Engine-neutral: the engine declares `s_blades: array<vec4<f32>>` (read_write
// where the template variable blades_writable is true, else read).

struct Blade {
    v0: vec3<f32>,
    orientation: f32,
    v1: vec3<f32>,
    height: f32,
    v2: vec3<f32>,
    width: f32,
    up: vec3<f32>,
    stiffness: f32,
};

fn load_blade(i: u32) -> Blade {
    let r0 = s_blades[4u * i + 0u];
    let r1 = s_blades[4u * i + 1u];
    let r2 = s_blades[4u * i + 2u];
    let r3 = s_blades[4u * i + 3u];
    return Blade(r0.xyz, r0.w, r1.xyz, r1.w, r2.xyz, r2.w, r3.xyz, r3.w);
}

$$ if blades_writable
fn store_blade(i: u32, b: Blade) {
    s_blades[4u * i + 0u] = vec4<f32>(b.v0, b.orientation);
    s_blades[4u * i + 1u] = vec4<f32>(b.v1, b.height);
    s_blades[4u * i + 2u] = vec4<f32>(b.v2, b.width);
    s_blades[4u * i + 3u] = vec4<f32>(b.up, b.stiffness);
}

// Write back only the rows the simulation changes (v1 and v2), half the memory traffic.
fn store_blade_guides(i: u32, b: Blade) {
    s_blades[4u * i + 1u] = vec4<f32>(b.v1, b.height);
    s_blades[4u * i + 2u] = vec4<f32>(b.v2, b.width);
}
$$ endif
