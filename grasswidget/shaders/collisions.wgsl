// The collision passes over the sphere colliders of the simulation uniforms
// (u_sim.n_colliders, u_sim.colliders: vec4 (centre xyz, radius w), m). Included by
// simulate.wgsl and inspect.wgsl (both declare u_sim) after blade_math.wgsl.
//
// The twins of reference.collide_spheres and reference.collision_passes. The loop
// over the colliders is here and only here (collide_spheres); everything it does
// per sphere is blade_math's collide_sphere, and the rest of a pass is blade_math's
// validate_pushed, both pure and held by tests/test_wgsl_contract.py.

// Collision passes per step (reference.COLLISION_PASSES): push, then validate the pushed blades.
const COLLISION_PASSES: i32 = {{ collision_passes }};

// One push of a blade out of every collider in turn (collide_sphere); add sums
// |d|^2 (m^2) over the spheres, hit says whether any of them pushed.
fn collide_spheres(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> Collision {
    var pushed = Collision(v2, 0.0, false);
    for (var c = 0; c < u_sim.n_colliders; c = c + 1) {
        let col = collide_sphere(v0, v1, pushed.v2, u_sim.colliders[c]);
        pushed = Collision(col.v2, pushed.add + col.add, pushed.hit || col.hit);
    }
    return pushed;
}

// A blade after the step's collisions, and the step's sum of |d|^2 (m^2) for gain_collision.
struct Collided { v1: vec3<f32>, v2: vec3<f32>, add: f32 };

// COLLISION_PASSES passes of collide_spheres, each followed by validate_pushed.
fn collision_passes(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> Collided {
    var blade = Guides(v1, v2);
    var add = 0.0;
    if (u_sim.n_colliders <= 0) { return Collided(v1, v2, add); }
    for (var pass_no = 0; pass_no < COLLISION_PASSES; pass_no = pass_no + 1) {
        let pushed = collide_spheres(v0, blade.v1, blade.v2);
        add = add + pushed.add;
        blade = validate_pushed(v0, blade.v1, blade.v2, up, height, pushed);
    }
    return Collided(blade.v1, blade.v2, add);
}
