// The browser engine's stand-in for pygfx.std.wgsl, included by blade_render.wgsl
// in place of pygfx's std include: the varyings and fragment output of the
// ribbon shader, and the colour helper it calls. The canvas stores sRGB values
// directly, so srgb2physical is the identity here (pygfx converts to linear and
// its output pass converts back: the same pixels for opaque blades).

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) along: f32,
    @location(3) base_color: vec3<f32>,  // the blade's unlit colour (blade_base_color)
    @location(4) @interpolate(flat) pick_idx: u32,
    @location(5) glow: f32,  // backlight of the tip (blade_math backlight)
    @location(6) fog: f32,   // distance fog share (blade_math fog_amount)
$$ if teaching_views
    @location(7) flat_color: vec4<f32>,  // colour-by views: a = 1 draws the blade flat in rgb (sRGB)
$$ endif
};

struct FragmentOutput {
    @location(0) color: vec4<f32>,
};

fn srgb2physical(color: vec3<f32>) -> vec3<f32> {
    return color;
}
