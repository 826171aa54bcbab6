// Sunlight (GrassParams.shadows): the balls' shadows, the grass layer's shadow and the sky's
// light under the grass, for the surfaces both engines draw: the ribbons (blade_render.wgsl),
// the compute rasterizer's resolve (raster_resolve.wgsl) and the ground (sky_ground.wgsl).
// Included after blade_math.wgsl by shaders whose u_material has the fields of
// uniform_layouts.SUNLIGHT_LAYOUT (values: engine_inputs.sunlight_values): light_direction (unit,
// towards the sun), shadow_balls (the first MAX_SHADOW_BALLS sphere colliders, radius 0 unused),
// shadow_field (the field's rectangle: xy centre (x, z), zw half sizes), shadow_depths (x the
// sun's and y the sky's optical depth per metre of grass height, z the layer's height, w the
// rectangle's soft edge, all m) and shadows (0 off, 1 on). Math: reference.shadows.
//
// Compiled in only while GrassParams.shadows is on (template switch `sunlight`: the kernel's
// materials set it from the values they write, the browser engine gets the shaders of the params'
// switch): a CPU adapter (lavapipe) runs the maths of an untaken branch too, so with shadows off
// blade_sunlight and ground_sunlight are constants and the rest is not compiled. Compiled in, they
// still test the uniform, together with per-pixel data (a branch on a uniform alone makes Mesa 22.3
// lavapipe compile a copy of the shader per draw), so the picture is the one without shadows
// whenever u_material.shadows is 0.

$$ if sunlight

// The sun's and the sky's visibility (0..1) at p (the field's space) under height_above metres of grass.
fn sun_and_sky(p: vec3<f32>, height_above: f32) -> vec2<f32> {
    let sun = u_material.light_direction.xyz;
    let field = u_material.shadow_field;
    let depths = u_material.shadow_depths;
    var visible = grass_transmittance(p.x, p.z, height_above, sun, field.xy, field.zw, depths.w, depths.x);
    for (var i = 0; i < {{ max_shadow_balls }}; i++) {
        visible *= ball_shadow(p, sun, u_material.shadow_balls[i]);
    }
    return vec2<f32>(visible, sky_visibility(p.x, p.z, height_above, field.xy, field.zw, depths.w, depths.y));
}

// A blade's point p at `along` (0 root .. 1 tip): (factor of its unlit colour, factor of its tips'
// glow); (1, 1) with shadows off. The blades narrow towards their tips: the leaf area above a point
// at `along` is about (1 - along)^2 of the layer's, so its grass above is that share of the layer's
// height (reference.shadows.grass_above).
fn blade_sunlight(p: vec3<f32>, along: f32, ambient: f32) -> vec2<f32> {
    var light = vec2<f32>(1.0, 1.0);
    if (u_material.shadows > 0.0 || along < -1.0) {
        let seen = sun_and_sky(p, grass_above(along, u_material.shadow_depths.z));
        light = vec2<f32>(light_share(seen.x, seen.y, ambient, 1.0, u_material.shadows),
                          1.0 + (seen.x - 1.0) * u_material.shadows);
    }
    return light;
}

// The ground's point p (under the whole layer where the field is): the factor of its lit
// colour, with its lighting's change with the sun's height (sun_scale: the sky/ground's
// u_material.ground_sun); 1 with shadows off.
fn ground_sunlight(p: vec3<f32>, sun_scale: f32) -> f32 {
    var factor = 1.0;
    if (u_material.shadows > 0.0 || p.y > 1e30) {
        let seen = sun_and_sky(p, u_material.shadow_depths.z);
        factor = light_share(seen.x, seen.y, {{ ground_ambient }}, sun_scale, u_material.shadows);
    }
    return factor;
}

$$ else
// Shadows off: no sunlight (the values the functions above give with u_material.shadows 0).
fn blade_sunlight(p: vec3<f32>, along: f32, ambient: f32) -> vec2<f32> {
    return vec2<f32>(1.0, 1.0);
}

fn ground_sunlight(p: vec3<f32>, sun_scale: f32) -> f32 {
    return 1.0;
}
$$ endif
