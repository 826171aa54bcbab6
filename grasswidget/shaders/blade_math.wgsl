// Blade math shared by the simulation, culling and drawing shaders.
//
// Every function here has a twin of the same name in grasswidget/core/reference/ (a package)
// (the NumPy reference, which is the spec). Equation numbers refer to
// Jahrmann & Wimmer, "Responsive Real-Time Grass Rendering for General 3D
// Scenes", I3D 2017. Units: metres, seconds, m/s^2.
//
// Engine-neutral: pure functions, no bindings. Ids and constants come from the
// template variables of grasswidget.core.shader_files.template_vars() (the enums of
// grasswidget/core/enums.py and the constants of the reference); tests/gpu/test_wgsl_contract.py
// runs every function here against its NumPy twin.

const PI_F = 3.141592653589793;

struct Basis { e1: vec3<f32>, e2: vec3<f32> };

// Two unit vectors spanning the plane orthogonal to up; for up = +y, (x, z).
fn tangent_basis(up: vec3<f32>) -> Basis {
    var reference = vec3<f32>(1.0, 0.0, 0.0);
    if (abs(up.x) > 0.9) { reference = vec3<f32>(0.0, 0.0, 1.0); }
    let e1 = normalize(reference - up * dot(reference, up));
    return Basis(e1, cross(e1, up));
}

// Width direction t1: e1 rotated by theta towards e2.
fn width_direction(up: vec3<f32>, theta: f32) -> vec3<f32> {
    let b = tangent_basis(up);
    return cos(theta) * b.e1 + sin(theta) * b.e2;
}

// Front direction f = normalize(cross(up, t1)).
fn front_direction(up: vec3<f32>, t1: vec3<f32>) -> vec3<f32> {
    return normalize(cross(up, t1));
}

// Environmental gravity gE (eq. 1): normalize(direction) * magnitude, or towards
// center (gravity_point) when gravity_mode is GravityMode.POINT.
fn environmental_gravity(v0: vec3<f32>, gravity_mode: i32, direction: vec3<f32>, center: vec3<f32>, magnitude: f32) -> vec3<f32> {
    if (gravity_mode == {{ gravity_mode_point }}) {
        return gravity_point(v0, center, magnitude);
    }
    return safe_normalize(direction) * magnitude;
}

// Front gravity gF = factor * |gE| * f (eq. 2).
fn front_gravity(g_env: vec3<f32>, f: vec3<f32>, factor: f32) -> vec3<f32> {
    return factor * length(g_env) * f;
}

// The "wave" wind field; see reference.wind_wave. dir is the unit direction (x, z).
fn wind_wave(p: vec3<f32>, t: f32, strength: f32, dir: vec2<f32>, speed: f32, wavelength: f32) -> vec3<f32> {
    let along = p.x * dir.x + p.z * dir.y;
    let across = -p.x * dir.y + p.z * dir.x;
    let a = 2.0 * PI_F * (along - speed * t) / wavelength;
    let b = 2.0 * PI_F * across / (1.7 * wavelength) + 0.5 * a;
    let amp = strength * (0.65 + 0.35 * sin(a)) * (0.85 + 0.15 * sin(b));
    return vec3<f32>(amp * dir.x, 0.0, amp * dir.y);
}

// Wind on the tip: w = W * fd * fr (eq. 3-5).
fn wind_force(W: vec3<f32>, v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    let wlen = length(W);
    if (wlen <= 1e-12) { return vec3<f32>(0.0); }
    let fd = 1.0 - abs(dot(W / wlen, normalize(v2 - v0)));
    let fr = dot(v2 - v0, up) / height;
    return W * (fd * fr);
}

// v2 += (accel + (iv2 - v2') s) dt, recovery taken at the end of the step.
fn integrate_tip(v2: vec3<f32>, iv2: vec3<f32>, stiffness: f32, accel: vec3<f32>, dt: f32) -> vec3<f32> {
    // Increment form of (v2 + dt (accel + s iv2)) / (1 + s dt): keeps float32 rounding small.
    return v2 + dt * (accel + stiffness * (iv2 - v2)) / (1.0 + stiffness * dt);
}

// State validation 1: v2 stays above the blade's ground plane.
fn validate_ground(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>) -> vec3<f32> {
    return v2 - up * min(dot(up, v2 - v0), 0.0);
}

// State validation 2: v1 from how far the tip leans (eq. 6-7).
fn validate_v1(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    let d = v2 - v0;
    let l_proj = length(d - up * dot(d, up));
    let ratio = l_proj / height;
    return v0 + up * (height * max(1.0 - ratio, 0.05 * max(ratio, 1.0)));
}

// L = (2 L0 + L1) / 3 (eq. 8 with n = 2).
fn curve_length(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> f32 {
    let l0 = length(v2 - v0);
    let l1 = length(v2 - v1) + length(v1 - v0);
    return (2.0 * l0 + l1) / 3.0;
}

struct Guides { v1: vec3<f32>, v2: vec3<f32> };

// State validation 3: scale the curve so that its length is h (eq. 9-10).
fn validate_length(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, height: f32) -> Guides {
    let k = height / max(curve_length(v0, v1, v2), 1e-12);
    let v1n = v0 + k * (v1 - v0);
    return Guides(v1n, v1n + k * (v2 - v1));
}

// ---------------------------------------------------------------- gravity point, more wind fields

// normalize() that gives 0 for a zero vector.
fn safe_normalize(v: vec3<f32>) -> vec3<f32> {
    return v / max(length(v), 1e-12);
}

// Gravity towards a point: gE = normalize(center - v0) * magnitude (gravity_mode "point").
fn gravity_point(v0: vec3<f32>, center: vec3<f32>, magnitude: f32) -> vec3<f32> {
    return safe_normalize(center - v0) * magnitude;
}

// Rings travelling outwards: 0.7 + 0.3 sin(2 pi (dist - speed t) / wavelength).
fn wind_pulse(dist: f32, t: f32, speed: f32, wavelength: f32) -> f32 {
    return 0.7 + 0.3 * sin(2.0 * PI_F * (dist - speed * t) / wavelength);
}

// The "radial" field (downwash): away from center; see reference.wind_radial.
fn wind_radial(p: vec3<f32>, t: f32, strength: f32, center: vec3<f32>, radius: f32, speed: f32, wavelength: f32) -> vec3<f32> {
    let r = p - center;
    let dist = length(r);
    let rho = dist / radius;
    return r * (strength * 2.0 / (radius * (1.0 + rho * rho)) * wind_pulse(dist, t, speed, wavelength));
}

// The "vortex" field: tangential (-r.z, 0, r.x) around the y axis through center.
fn wind_vortex(p: vec3<f32>, t: f32, strength: f32, center: vec3<f32>, radius: f32, speed: f32, wavelength: f32) -> vec3<f32> {
    let r = p - center;
    let dist = length(r);
    let rho = dist / radius;
    let k = strength * 2.0 / (radius * (1.0 + rho * rho)) * wind_pulse(dist, t, speed, wavelength);
    return vec3<f32>(-r.z, 0.0, r.x) * k;
}

// 32-bit hash of lattice coordinates (u32 wrap-around); see reference.noise_hash.
fn noise_hash(i: i32, j: i32) -> u32 {
    var h = (bitcast<u32>(i) * 0x8da6b343u) ^ (bitcast<u32>(j) * 0xd8163841u);
    h = h ^ (h >> 16u);
    h = h * 0x7feb352du;
    h = h ^ (h >> 15u);
    h = h * 0x846ca68bu;
    h = h ^ (h >> 16u);
    return h;
}

// The 8 unit gradients (cos, sin) of k * 45 degrees, as constants: cos/sin of
// angles up to 315 degrees are only accurate to 2^-11 in WGSL, and GPUs differ there.
const SIMPLEX_GRADIENTS = array<vec2<f32>, 8>(
    vec2<f32>(1.0, 0.0), vec2<f32>(0.7071067811865476, 0.7071067811865476),
    vec2<f32>(0.0, 1.0), vec2<f32>(-0.7071067811865476, 0.7071067811865476),
    vec2<f32>(-1.0, 0.0), vec2<f32>(-0.7071067811865476, -0.7071067811865476),
    vec2<f32>(0.0, -1.0), vec2<f32>(0.7071067811865476, -0.7071067811865476),
);

fn simplex_corner(x: f32, y: f32, i: i32, j: i32) -> f32 {
    let t = max(0.5 - x * x - y * y, 0.0);
    // SIMPLEX_GRADIENTS[k] by selects, not an indexed load (a CPU's vector lanes would each load
    // from their own index: a gather): k = 2 q + odd, q the quarter turn, the same constants.
    let k = noise_hash(i, j) & 7u;
    let q = k >> 1u;
    let d = SIMPLEX_GRADIENTS[1].x;
    let axis = vec2<f32>(select(select(0.0, -1.0, q == 2u), 1.0, q == 0u), select(select(0.0, -1.0, q == 3u), 1.0, q == 1u));
    let diagonal = vec2<f32>(select(-d, d, q == 0u || q == 3u), select(-d, d, q < 2u));
    let g = select(axis, diagonal, (k & 1u) == 1u);
    let t2 = t * t;
    return t2 * t2 * (g.x * x + g.y * y);
}

// 2D simplex noise, about [-1, 1]; see reference.simplex_noise2.
fn simplex_noise2(x: f32, y: f32) -> f32 {
    let F2 = 0.36602540378443865;
    let G2 = 0.21132486540518713;
    let s = (x + y) * F2;
    let i = floor(x + s);
    let j = floor(y + s);
    let t = (i + j) * G2;
    let x0 = x - (i - t);
    let y0 = y - (j - t);
    var i1 = 0.0;
    if (x0 > y0) { i1 = 1.0; }
    let j1 = 1.0 - i1;
    let ii = i32(i);
    let jj = i32(j);
    let n = simplex_corner(x0, y0, ii, jj)
        + simplex_corner(x0 - i1 + G2, y0 - j1 + G2, ii + i32(i1), jj + i32(j1))
        + simplex_corner(x0 - 1.0 + 2.0 * G2, y0 - 1.0 + 2.0 * G2, ii + 1, jj + 1);
    return {{ noise_scale }} * n;
}

// The "noise" field: gusts from simplex noise drifting with the wind; see reference.wind_noise.
// dir is the unit wind direction (x, z), direction_rad its angle.
fn wind_noise(p: vec3<f32>, t: f32, strength: f32, dir: vec2<f32>, direction_rad: f32, speed: f32, scale: f32) -> vec3<f32> {
    let qx = (p.x - dir.x * speed * t) / scale;
    let qz = (p.z - dir.y * speed * t) / scale;
    let angle = direction_rad + 0.5 * PI_F * simplex_noise2(qx, qz);
    let amp = strength * clamp(0.6 + 0.5 * simplex_noise2(qx + 31.7, qz + 17.3), 0.0, 1.0);
    return vec3<f32>(amp * cos(angle), 0.0, amp * sin(angle));
}

// ---------------------------------------------------------------- collisions

// Push moving p out of a sphere (c.xyz, radius c.w); see reference.sphere_push.
fn sphere_push(p: vec3<f32>, c: vec4<f32>) -> vec3<f32> {
    let diff = c.xyz - p;
    let dist = length(diff);
    if (dist >= c.w) { return vec3<f32>(0.0); }
    return diff * ((dist - c.w) / max(dist, 1e-12));
}

struct Collision { v2: vec3<f32>, add: f32, hit: bool };

// One sphere of reference.collide_spheres: push v2, then the midpoint (v2 by 4 d).
fn collide_sphere(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, sphere: vec4<f32>) -> Collision {
    var tip = v2;
    let d_tip = sphere_push(tip, sphere);
    tip = tip + d_tip;
    let d_mid = sphere_push(0.25 * v0 + 0.5 * v1 + 0.25 * tip, sphere);
    tip = tip + 4.0 * d_mid;
    let add = dot(d_tip, d_tip) + dot(d_mid, d_mid);
    return Collision(tip, add, add > 0.0);
}

// Whether a sphere (c.xyz, radius c.w) comes near enough to act on a blade rooted at v0 of
// this height: |c - v0| < radius + COLLIDER_REACH * height; see reference.sphere_in_reach.
fn sphere_in_reach(v0: vec3<f32>, height: f32, sphere: vec4<f32>) -> bool {
    return length(sphere.xyz - v0) < sphere.w + {{ collider_reach }} * height;
}

// Cell (cz * nx + cx) of the collider grid holding p's (x, z): cells of 1 / inv_cell_size
// metres from origin, indices clamped to the grid (border cells reach to infinity);
// see reference.grid_cell.
fn grid_cell(p: vec3<f32>, origin: vec2<f32>, inv_cell_size: f32, nx: u32, nz: u32) -> u32 {
    let q = (p.xz - origin) * inv_cell_size;
    let cx = u32(clamp(floor(q.x), 0.0, f32(nx - 1u)));
    let cz = u32(clamp(floor(q.y), 0.0, f32(nz - 1u)));
    return cz * nx + cx;
}

// eta' = max(eta - fade dt, 0); see reference.fade_collision.
fn fade_collision(eta: f32, fade: f32, dt: f32) -> f32 {
    return max(eta - fade * dt, 0.0);
}

// eta' = min(eta + gain * add, COLLISION_MAX): a step's pushes (add = sum |d|^2, m^2)
// strengthen the collision; see reference.gain_collision.
fn gain_collision(eta: f32, add: f32, gain: f32) -> f32 {
    return min(eta + gain * add, {{ collision_max }});
}

// Recovery stiffness of a blade with collision strength eta: s * max(1 - eta, RECOVERY_FLOOR).
fn effective_stiffness(stiffness: f32, eta: f32) -> f32 {
    return stiffness * max(1.0 - eta, {{ recovery_floor }});
}

// The blade after one collision pass: where a sphere pushed it (pushed.hit), the
// pushed tip validated again (validate_state); elsewhere unchanged. pushed is the
// pass's pushes over all spheres (collide_sphere in turn; see collisions.wgsl).
fn validate_pushed(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32, pushed: Collision) -> Guides {
    if (!pushed.hit) { return Guides(v1, v2); }
    return validate_state(v0, pushed.v2, up, height);
}

// ---------------------------------------------------------------- one step of the tip

// The paper's state validation (section 5.2) of a moved tip v2: above the ground,
// v1 from the lean, then the curve scaled to length height.
fn validate_state(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> Guides {
    let v2g = validate_ground(v0, v2, up);
    return validate_length(v0, validate_v1(v0, v2g, up, height), v2g, height);
}

// One fixed step dt of the tip (paper 5.1-5.2), collisions aside: the wind W at v0
// (m/s^2) becomes the wind force, gravity (gE + gF, m/s^2) is added, recovery of
// the given (effective) stiffness (1/s) pulls towards v0 + up * height, then
// validate_state. Returns the new (v1, v2).
fn tip_step(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32, stiffness: f32, gravity: vec3<f32>, wind: vec3<f32>, dt: f32) -> Guides {
    let w = wind_force(wind, v0, v2, up, height);
    let moved = integrate_tip(v2, v0 + up * height, stiffness, gravity + w, dt);
    return validate_state(v0, moved, up, height);
}

// ---------------------------------------------------------------- finite state

// Whether every component of v is a finite number (neither NaN nor +-inf), read from the
// bits: an exponent of all ones marks both (a compiler may assume that floats are finite
// and fold a test like x != x away). See reference.finite3.
fn finite3(v: vec3<f32>) -> bool {
    let exponent = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(exponent != vec3<u32>(0x7f800000u));
}

// A blade after a step's validation: its guides, collision strength eta, and whether it
// was put back at rest.
struct Settled { v1: vec3<f32>, v2: vec3<f32>, eta: f32, reset: bool };

// The last state validation of a step: a blade whose guides or collision strength are not
// all finite (a user's wind WGSL that returned NaN or inf) goes back to rest, v1 = v2 =
// v0 + up * height and eta = 0, with reset set; any other blade is unchanged. See
// reference.validate_finite.
fn validate_finite(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32, eta: f32) -> Settled {
    if (finite3(v1) && finite3(v2) && finite3(vec3<f32>(eta))) {
        return Settled(v1, v2, eta, false);
    }
    let rest = v0 + up * height;
    return Settled(rest, rest, 0.0, true);
}

// ---------------------------------------------------------------- culling

// Seen edge-on: |dot(normalize(v0 - cam), t1)| > threshold.
fn orientation_cull(v0: vec3<f32>, t1: vec3<f32>, cam_pos: vec3<f32>, threshold: f32) -> bool {
    return abs(dot(normalize(v0 - cam_pos), t1)) > threshold;
}

// A clip-space point outside the view (with slack tol on x and y).
fn clip_outside(clip: vec4<f32>, tol: f32) -> bool {
    let lim = clip.w + tol;
    let inside = abs(clip.x) <= lim && abs(clip.y) <= lim && clip.z >= 0.0 && clip.z <= clip.w;
    return !inside;
}

// v0, the curve midpoint and v2 all outside the view (clip space, with slack).
fn frustum_cull(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, view_proj: mat4x4<f32>, tol: f32) -> bool {
    let m = 0.25 * v0 + 0.5 * v1 + 0.25 * v2;
    return clip_outside(view_proj * vec4<f32>(v0, 1.0), tol)
        && clip_outside(view_proj * vec4<f32>(m, 1.0), tol)
        && clip_outside(view_proj * vec4<f32>(v2, 1.0), tol);
}

// Bucketed thinning: cull if id mod n >= ceil(n * max(1 - d_proj / d_max, 0)).
fn distance_cull(v0: vec3<f32>, up: vec3<f32>, cam_pos: vec3<f32>, id: u32, buckets: u32, d_max: f32) -> bool {
    let d = v0 - cam_pos;
    let d_proj = length(d - up * dot(d, up));
    let keep = ceil(f32(buckets) * max(1.0 - d_proj / d_max, 0.0));
    return f32(id % buckets) >= keep;
}

// Projected blade height in pixels, from the clip w of the curve's middle.
fn projected_pixels(v0: vec3<f32>, v2: vec3<f32>, height: f32, view_proj: mat4x4<f32>, viewport_height: f32) -> f32 {
    let mid = 0.5 * (v0 + v2);
    let w = max((view_proj * vec4<f32>(mid, 1.0)).w, 1e-6);
    let focal = length(vec3<f32>(view_proj[0].y, view_proj[1].y, view_proj[2].y));
    return height * focal * viewport_height * 0.5 / w;
}

// ---------------------------------------------------------------- occlusion

// A blade's screen bounds for the occlusion test: rect (x0, y0, x1, y1) in pixels
// (y down, clamped to the view) and the nearest depth (0 near .. 1 far).
struct ScreenBounds { rect: vec4<f32>, depth: f32 };

// The box around v0, v1, v2 grown by radius, its 8 corners projected; a box that
// reaches behind the near plane gets the whole view and depth 0 (never hidden).
fn occlusion_bounds(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, radius: f32, view_proj: mat4x4<f32>, viewport_size: vec2<f32>) -> ScreenBounds {
    let lo = min(min(v0, v1), v2) - vec3<f32>(radius);
    let hi = max(max(v0, v1), v2) + vec3<f32>(radius);
    var nmin = vec3<f32>(1e30);
    var nmax = vec3<f32>(-1e30);
    var behind = false;
    for (var k = 0u; k < 8u; k += 1u) {
        let corner = select(lo, hi, vec3<bool>((k & 1u) != 0u, (k & 2u) != 0u, (k & 4u) != 0u));
        let clip = view_proj * vec4<f32>(corner, 1.0);
        behind = behind || clip.w <= 1e-6 || clip.z < 0.0;
        let ndc = clip.xyz / select(clip.w, 1.0, clip.w <= 1e-6);
        nmin = min(nmin, ndc);
        nmax = max(nmax, ndc);
    }
    var b: ScreenBounds;
    if (behind) {
        b.rect = vec4<f32>(0.0, 0.0, viewport_size.x, viewport_size.y);
        b.depth = 0.0;
        return b;
    }
    let x0 = clamp((nmin.x * 0.5 + 0.5) * viewport_size.x, 0.0, viewport_size.x);
    let x1 = clamp((nmax.x * 0.5 + 0.5) * viewport_size.x, 0.0, viewport_size.x);
    let y0 = clamp((0.5 - 0.5 * nmax.y) * viewport_size.y, 0.0, viewport_size.y);
    let y1 = clamp((0.5 - 0.5 * nmin.y) * viewport_size.y, 0.0, viewport_size.y);
    b.rect = vec4<f32>(x0, y0, x1, y1);
    b.depth = max(nmin.z, 0.0);
    return b;
}

// The max-depth pyramid level at which a pixel rect spans at most {{ hzb_span_texels }} + 1 texels
// each way (reference.hzb_level, HZB_SPAN_TEXELS).
fn hzb_level(rect: vec4<f32>) -> u32 {
    let span = u32(max(ceil(max(rect.z - rect.x, rect.w - rect.y)), 1.0));
    var level = 0u;
    while ({{ hzb_span_texels }}u * (1u << level) < span) { level += 1u; }
    return level;
}

// ---------------------------------------------------------------- drawing

// Across-blade parameter t for the blade shapes of the paper, u, v in [0, 1].
// shape: a BladeShape id; triangle-tip narrows above v = tau; fold is 3D, like quad across.
fn blade_shape_t(u: f32, v: f32, shape: i32, tau: f32) -> f32 {
    switch shape {
        case {{ blade_shape_quad }}, {{ blade_shape_fold }}: { return u; }
        case {{ blade_shape_triangle }}: { return u + 0.5 * v - u * v; }
        case {{ blade_shape_quadratic }}: { return u - u * v * v; }
        default: { return 0.5 + (u - 0.5) * (1.0 - max(v - tau, 0.0) / (1.0 - tau)); }
    }
}

// Hash of a blade id to [0, 1), for per-blade colour variation.
fn hash01(x: u32) -> f32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    h = (h >> 22u) ^ h;
    return f32(h) / 4294967296.0;
}

// ---------------------------------------------------------------- looks (colour, soil, sky, fog)

// The meadow's low-frequency patches (clumps) at ground point (x, z): two independent
// simplex noises of feature size `size` metres, each clamped to [-1, 1]; x drives a
// patch's hue and brightness, y its dryness. See reference.clump_noise.
fn clump_noise(x: f32, z: f32, size: f32) -> vec2<f32> {
    let qx = x / size;
    let qz = z / size;
    let a = simplex_noise2(qx, qz);
    let b = simplex_noise2(qx + 19.1, qz - 7.3);
    return clamp(vec2<f32>(a, b), vec2<f32>(-1.0), vec2<f32>(1.0));
}

// Unlit sRGB colour of a blade at height fraction `along` (0 root .. 1 tip): the
// root-to-tip gradient, brightness and hue shifted by the blade's patch (clump.x) and
// its own hash (`variation`, 0..1) times color_variation, then towards straw in dry
// patches (clump.y, dryness 0..1; tips dry first). See reference.blade_base_color.
fn blade_base_color(root: vec3<f32>, tip: vec3<f32>, along: f32, variation: f32, clump: vec2<f32>, color_variation: f32, dryness: f32) -> vec3<f32> {
    let v = clamp(along, 0.0, 1.0);
    let ramp = pow(v, 0.8);
    var base = mix(root, tip, ramp);
    let s = 0.7 * clump.x + 0.6 * (variation - 0.5);
    base = base * (1.0 + 0.5 * color_variation * s);
    base = base + color_variation * s * vec3<f32>(0.22, 0.05, -0.15) * tip;
    let dry = clamp(dryness * (1.0 + 1.5 * clump.y), 0.0, 1.0) * (0.4 + 0.6 * v);
    let straw = vec3<f32>({{ dry_color }}) * (0.45 + 0.55 * ramp);
    return clamp(mix(base, straw, dry), vec3<f32>(0.0), vec3<f32>(1.0));
}

// Light through a blade seen against the sun: translucency * max(dot(-to_eye, light), 0)^4
// * along^2 (tips glow most). to_eye, light: unit vectors. See reference.backlight.
fn backlight(to_eye: vec3<f32>, light: vec3<f32>, along: f32, translucency: f32) -> f32 {
    let facing = max(dot(-to_eye, light), 0.0);
    let f2 = facing * facing;
    let a = clamp(along, 0.0, 1.0);
    return translucency * f2 * f2 * a * a;
}

// Share of the fog colour at `distance` metres: 1 - exp(-density * distance) (0 = no fog).
fn fog_amount(distance: f32, density: f32) -> f32 {
    return 1.0 - exp(-max(density, 0.0) * max(distance, 0.0));
}

// Sky colour for a view ray of elevation sin `elevation` (-1..1): the horizon colour at
// and below the horizon, towards the zenith colour as the ray rises (square root ramp).
fn sky_color(elevation: f32, horizon: vec3<f32>, zenith: vec3<f32>) -> vec3<f32> {
    return mix(horizon, zenith, sqrt(clamp(elevation, 0.0, 1.0)));
}

// How far ground point (x, z) lies inside the field's rectangle (centre c, half sizes
// half, metres): 0 outside beyond edge / 2, 1 inside beyond edge / 2, linear between.
fn field_inside(x: f32, z: f32, c: vec2<f32>, half: vec2<f32>, edge: f32) -> f32 {
    let d = max(abs(x - c.x) - half.x, abs(z - c.y) - half.y);
    return clamp(0.5 - d / edge, 0.0, 1.0);
}

// Ground colour (sRGB): the soil under the field, darkened by the grass' cover (0..1,
// GrassScene: 1 - exp(-leaf area / 4)), blended by `inside` (field_inside) with the ground
// beyond. See reference.ground_color.
fn ground_color(soil: vec3<f32>, beyond: vec3<f32>, inside: f32, cover: f32) -> vec3<f32> {
    let under = soil * (1.0 - 0.6 * clamp(cover, 0.0, 1.0));
    return mix(beyond, under, clamp(inside, 0.0, 1.0));
}

// Lit colour of a blade's surface point (sRGB, 0..1): the ribbons' fragment shading,
// also the compute rasterizer's resolve. normal: the surface normal (either side:
// two-sided, the side facing the eye is lit), to_eye: unit vector towards the camera,
// along: 0 root .. 1 tip, base: the blade's unlit colour there (blade_base_color),
// glow: its backlight (backlight), fog: its fog share (fog_amount) towards fog_color;
// the material's light direction (towards the light) and ambient (0..1). Tips seen
// against the sun glow (light through the blade), warmer than the blade.
fn blade_shade(normal: vec3<f32>, to_eye: vec3<f32>, along: f32, base: vec3<f32>, glow: f32, fog: f32, fog_color: vec3<f32>, light_direction: vec3<f32>, ambient: f32) -> vec3<f32> {
    var n = normalize(normal);
    if (dot(n, to_eye) < 0.0) { n = -n; }
    let l = normalize(light_direction);
    let diffuse = max(dot(n, l), 0.0);
    let translucency = 0.35 * max(dot(-n, l), 0.0);
    let ao = 0.55 + 0.45 * clamp(along, 0.0, 1.0);
    let shade = (ambient + (1.0 - ambient) * (diffuse + translucency)) * ao;
    let rgb = clamp(base * shade + glow * (1.2 * base + vec3<f32>(0.16, 0.14, 0.02)), vec3<f32>(0.0), vec3<f32>(1.0));
    return mix(rgb, fog_color, fog);
}

// ---------------------------------------------------------------- sunlight (reference.shadows)

// How much of the sun (unit direction `sun`) point p sees past one ball (x, y, z, r), 0 (core of
// its shadow) .. 1; r <= 0 (an unused slot) casts none. Soft edge: a penumbra of
// BALL_PENUMBRA per metre between ball and point plus 5 % of the radius, faded out as the ball
// moves behind the point.
fn ball_shadow(p: vec3<f32>, sun: vec3<f32>, ball: vec4<f32>) -> f32 {
    let to_c = ball.xyz - p;
    let t = dot(to_c, sun);
    let d = length(to_c - t * sun);
    let w = max({{ ball_penumbra }} * max(t, 0.0) + 0.05 * ball.w, 1e-5);
    let vis = clamp((d - ball.w) / (2.0 * w) + 0.5, 0.0, 1.0);
    let ahead = clamp(t / max(ball.w, 1e-6) + 1.0, 0.0, 1.0);
    return select(1.0 - (1.0 - vis) * ahead, 1.0, ball.w <= 0.0);
}

// The share of the sun's light reaching ground point (x, z) through height_above metres of the
// grass layer: exp(-depth_per_m * height_above * f), f the share of the sun ray's way through
// the layer that lies over the field's rectangle (c, half, edge: field_inside), sampled at
// TRANSMITTANCE_TAPS points.
fn grass_transmittance(x: f32, z: f32, height_above: f32, sun: vec3<f32>, c: vec2<f32>, half: vec2<f32>, edge: f32, depth_per_m: f32) -> f32 {
    let h = max(height_above, 0.0);
    let reach = sun.xz / max(sun.y, {{ sun_min_y }}) * h;
    var inside = 0.0;
    for (var tap = 0; tap < {{ transmittance_taps }}; tap++) {
        let s = (f32(tap) + 0.5) / f32({{ transmittance_taps }});
        inside += field_inside(x + s * reach.x, z + s * reach.y, c, half, edge);
    }
    return exp(-depth_per_m * h * inside / f32({{ transmittance_taps }}));
}

// The grass layer (layer_height m deep) above a blade's point at along (0 root .. 1 tip), as metres
// of layer: (1 - along)^2 layer_height (blades narrow towards the tip: the leaf area above).
fn grass_above(along: f32, layer_height: f32) -> f32 {
    let a = 1.0 - clamp(along, 0.0, 1.0);
    return a * a * layer_height;
}

// The share of the sky's light reaching ground point (x, z) under height_above metres of grass.
fn sky_visibility(x: f32, z: f32, height_above: f32, c: vec2<f32>, half: vec2<f32>, edge: f32, depth_per_m: f32) -> f32 {
    return exp(-depth_per_m * max(height_above, 0.0) * field_inside(x, z, c, half, edge));
}

// The factor of a surface's lit colour: the ambient share lit by the sky (at least SKY_FLOOR
// of it), the rest by the sun times sun_scale; strength 0 gives 1 (no shadows).
fn light_share(sun_visible: f32, sky_visible: f32, ambient: f32, sun_scale: f32, strength: f32) -> f32 {
    let a = clamp(ambient, 0.0, 1.0);
    let sky = {{ sky_floor }} + (1.0 - {{ sky_floor }}) * sky_visible;
    let lit = a * sky + (1.0 - a) * sun_visible * sun_scale;
    return 1.0 + (lit - 1.0) * strength;
}

// ---------------------------------------------------------------- compute rasterization

// A clip-space point in pixels (x right, y down from the view's top-left corner) and
// its depth (z: 0 near .. 1 far); viewport_size in pixels.
fn clip_to_pixel(clip: vec4<f32>, viewport_size: vec2<f32>) -> vec3<f32> {
    let ndc = clip.xyz / clip.w;
    return vec3<f32>((ndc.x * 0.5 + 0.5) * viewport_size.x, (0.5 - 0.5 * ndc.y) * viewport_size.y, ndc.z);
}

// The compute walk's step along a blade's curve at v: the screen speed of the curve
// there is |2 (1 - v) (s1 - s0) + 2 v (s2 - s1)| pixels per unit v (s0, s1, s2: the
// control points in pixels), and the step is 0.9 / speed, so consecutive samples are
// about 0.9 pixels apart wherever the curve goes (no gaps, no pile-up of samples where
// it slows down); at least 1 / RASTER_MAX_SAMPLES, at most 1.
fn raster_step(s0: vec2<f32>, s1: vec2<f32>, s2: vec2<f32>, v: f32) -> f32 {
    let speed = length(2.0 * (1.0 - v) * (s1 - s0) + 2.0 * v * (s2 - s1));
    return clamp(0.9 / max(speed, 1e-6), 1.0 / {{ raster_max_samples }}, 1.0);
}

// The two ends of a blade's cross-section on screen: pixels x, y and depth.
struct RasterSpan { a: vec3<f32>, b: vec3<f32> };

// The cross-section of the ribbon at v (0 root .. 1 tip) on screen, tapered like the
// ribbons (blade_shape_t at u = 0 and u = 1). c0, c1, c2: the control points in clip
// space (the curve is the quadratic Bezier there, exact on screen after the divide);
// across_px: the blade's half-width vector in clip space (view_proj * (width t1, 0))
// times (0.5 width, -0.5 height) of the view, once per blade: divided by the curve
// point's w it is the half width in pixels there. The ends are the projected curve point
// plus (2 t - 1) times that half width, both at the curve point's depth (a thin blade's
// depth across its width, and the perspective across it, are left out).
fn raster_section(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, across_px: vec2<f32>, v: f32, shape: i32, tau: f32, viewport_size: vec2<f32>) -> RasterSpan {
    let a = c0 + v * (c1 - c0);
    let b = c1 + v * (c2 - c1);
    let c = a + v * (b - a);
    let inv_w = 1.0 / c.w;
    let centre = vec3<f32>((c.x * inv_w * 0.5 + 0.5) * viewport_size.x, (0.5 - 0.5 * c.y * inv_w) * viewport_size.y, c.z * inv_w);
    let half = across_px * inv_w;
    let left = 2.0 * blade_shape_t(0.0, v, shape, tau) - 1.0;
    let right = 2.0 * blade_shape_t(1.0, v, shape, tau) - 1.0;
    return RasterSpan(centre + vec3<f32>(left * half, 0.0), centre + vec3<f32>(right * half, 0.0));
}

// Coverage of a cross-section span_px pixels wide: how many points the walk writes
// across it, floor(span_px + h) with h = hash01 of the blade and the sample (a
// stochastic rounding: on average span_px pixels, like the hardware rasterizer's
// pixel-centre rule, narrower than a pixel included; the same pixels from frame to
// frame, so no shimmer), at most RASTER_MAX_ACROSS.
fn raster_cover(blade: u32, sample: u32, span_px: f32) -> u32 {
    let h = hash01(blade * 2654435761u + sample * 40503u);
    return u32(clamp(floor(span_px + h), 0.0, {{ raster_max_across }}));
}

// The shading payload of a rasterized pixel: blade id (< 2^24) << 8 | v in 1/255 steps.
fn raster_payload(blade: u32, v: f32) -> u32 {
    return (blade << 8u) | u32(round(clamp(v, 0.0, 1.0) * 255.0));
}

// ---------------------------------------------------------------- camera-following levels (core/horizon.py)

// Level of blade i: how many level ends (the first id after each level; ends_lo levels 0..3,
// ends_hi 4..7, unused ones 0xffffffff) are <= i, at most n_levels - 1; see reference.level_index.
fn level_index(i: u32, ends_lo: vec4<u32>, ends_hi: vec4<u32>, n_levels: u32) -> u32 {
    let a = select(vec4<u32>(0u), vec4<u32>(1u), vec4<u32>(i) >= ends_lo);
    let b = select(vec4<u32>(0u), vec4<u32>(1u), vec4<u32>(i) >= ends_hi);
    return min(a.x + a.y + a.z + a.w + b.x + b.y + b.z + b.w, max(n_levels, 1u) - 1u);
}

// The (x, z) shift moving a root at p to its copy nearest the camera at cam on a plane repeated
// every period metres: period * round((cam - p) / period); see reference.wrap_shift.
fn wrap_shift(p: vec2<f32>, cam: vec2<f32>, period: f32) -> vec2<f32> {
    return period * round((cam - p) / period);
}

// Weight (0..1) of a blade of a level at distance d (m) from the camera to its root:
// smoothstep(bands.x, bands.y, d) * (1 - smoothstep(bands.z, bands.w, d)), its level's fade-in
// and fade-out bands; see reference.level_weight.
fn level_weight(d: f32, bands: vec4<f32>) -> f32 {
    return smoothstep(bands.x, bands.y, d) * (1.0 - smoothstep(bands.z, bands.w, d));
}
