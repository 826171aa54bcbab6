// The browser engine's scene around the grass: the sky gradient, the ground
// plane and the translucent collider balls (the kernel engine draws these with
// pygfx's Background, a Phong plane and Phong spheres; colours measured there).
// StdInfo is prepended by grasswidget.browser.wgsl.

struct SceneUniforms {
    sky_bottom: vec4<f32>,
    sky_top: vec4<f32>,
    ground_color: vec4<f32>,
    ground_center: vec4<f32>,   // xyz centre, w half extent
    ball_color: vec4<f32>,      // rgb, a opacity
    light_direction: vec4<f32>,
};

@group(0) @binding(0) var<uniform> u_stdinfo: StdInfo;
@group(0) @binding(1) var<uniform> u_scene: SceneUniforms;
@group(0) @binding(2) var<storage, read> s_balls: array<vec4<f32>>;

struct SkyOut {
    @builtin(position) position: vec4<f32>,
    @location(0) v: f32,
};

@vertex
fn vs_sky(@builtin(vertex_index) k: u32) -> SkyOut {
    let xy = vec2<f32>(f32((k << 1u) & 2u), f32(k & 2u)) * 2.0 - 1.0;
    var out: SkyOut;
    out.position = vec4<f32>(xy, 0.9999999, 1.0);
    out.v = 0.5 * (xy.y + 1.0);
    return out;
}

@fragment
fn fs_sky(in: SkyOut) -> @location(0) vec4<f32> {
    return vec4<f32>(mix(u_scene.sky_bottom.rgb, u_scene.sky_top.rgb, in.v), 1.0);
}

struct GroundOut {
    @builtin(position) position: vec4<f32>,
};

@vertex
fn vs_ground(@builtin(vertex_index) k: u32) -> GroundOut {
    let corner = array<vec2<f32>, 4>(vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(-1.0, 1.0), vec2<f32>(1.0, 1.0));
    let c = corner[k];
    let half = u_scene.ground_center.w;
    let p = vec3<f32>(u_scene.ground_center.x + c.x * half, u_scene.ground_center.y, u_scene.ground_center.z + c.y * half);
    var out: GroundOut;
    out.position = u_stdinfo.projection_transform * u_stdinfo.cam_transform * vec4<f32>(p, 1.0);
    return out;
}

@fragment
fn fs_ground(in: GroundOut) -> @location(0) vec4<f32> {
    return vec4<f32>(u_scene.ground_color.rgb, 1.0);
}

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
    let l = normalize(u_scene.light_direction.xyz);
    let n = normalize(in.normal);
    let cam = u_stdinfo.cam_transform_inv[3].xyz;
    let to_eye = normalize(cam - in.world_pos);
    let h = normalize(l + to_eye);
    let diffuse = max(dot(n, l), 0.0);
    let spec = pow(max(dot(n, h), 0.0), 60.0);
    let rgb = u_scene.ball_color.rgb * (0.75 + 0.45 * diffuse) + vec3<f32>(0.35 * spec);
    return vec4<f32>(min(rgb, vec3<f32>(1.0)), u_scene.ball_color.a);
}
