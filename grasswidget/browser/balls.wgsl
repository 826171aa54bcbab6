// The browser engine's translucent collider balls (the kernel engine draws them
// with pygfx's Phong spheres, grasswidget.gpu.collider_view). Sky and ground are
// shaders/sky_ground.wgsl, drawn by both engines. StdInfo and BallStyle
// (grasswidget.browser.uniforms.BALL_LAYOUT) are prepended by grasswidget.browser.browser_wgsl.

@group(0) @binding(0) var<uniform> u_stdinfo: StdInfo;
@group(0) @binding(1) var<uniform> u_balls: BallStyle;
@group(0) @binding(2) var<storage, read> s_balls: array<vec4<f32>>;

struct BallOut {
    @builtin(position) position: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) world_pos: vec3<f32>,
};

const BALL_RINGS: u32 = 16u;
const BALL_SEGMENTS: u32 = 32u;

// A UV sphere as a triangle list: 6 vertices per quad, BALL_RINGS x BALL_SEGMENTS quads per ball.
@vertex
fn vs_ball(@builtin(vertex_index) k: u32, @builtin(instance_index) ball: u32) -> BallOut {
    let quad = k / 6u;
    let corner = array<vec2<u32>, 6>(vec2<u32>(0u, 0u), vec2<u32>(1u, 0u), vec2<u32>(0u, 1u),
                                     vec2<u32>(0u, 1u), vec2<u32>(1u, 0u), vec2<u32>(1u, 1u))[k % 6u];
    let seg = quad % BALL_SEGMENTS + corner.x;
    let ring = quad / BALL_SEGMENTS + corner.y;
    let phi = 6.283185307179586 * f32(seg) / f32(BALL_SEGMENTS);
    let theta = 3.141592653589793 * f32(ring) / f32(BALL_RINGS);
    let n = vec3<f32>(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
    let sphere = s_balls[ball];
    let p = sphere.xyz + sphere.w * n;
    var out: BallOut;
    out.position = u_stdinfo.projection_transform * u_stdinfo.cam_transform * vec4<f32>(p, 1.0);
    out.normal = n;
    out.world_pos = p;
    return out;
}

@fragment
fn fs_ball(in: BallOut) -> @location(0) vec4<f32> {
    let l = normalize(u_balls.light_direction.xyz);
    let n = normalize(in.normal);
    let cam = u_stdinfo.cam_transform_inv[3].xyz;
    let to_eye = normalize(cam - in.world_pos);
    let h = normalize(l + to_eye);
    let diffuse = max(dot(n, l), 0.0);
    let spec = pow(max(dot(n, h), 0.0), 60.0);
    let rgb = u_balls.ball_color.rgb * (0.75 + 0.45 * diffuse) + vec3<f32>(0.35 * spec);
    return vec4<f32>(min(rgb, vec3<f32>(1.0)), u_balls.ball_color.a);
}
