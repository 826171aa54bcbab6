// The collision passes over the sphere colliders. Included by simulate.wgsl and
// inspect.wgsl after blade_math.wgsl; expects, declared by the engine: u_sim
// (n_colliders), s_colliders: array<vec4<f32>> (centre xyz, radius w; m) and
// s_collider_grid: array<u32> (the grid of grasswidget.core.collider_grid: header,
// per cell (first list word, count), the lists of sphere indices), both read-only.
//
// The twins of reference.collide_spheres and reference.collision_passes (and of
// collider_grid.collider_cell_range). A blade tests only the spheres listed in its
// root's grid cell: every sphere in reach (sphere_in_reach), in ascending order, so
// the result equals the reference's loop over all spheres. Everything done per
// sphere is blade_math's collide_sphere, the rest of a pass blade_math's
// validate_pushed, both pure and held by tests/test_wgsl_contract.py.

// Collision passes per step (reference.COLLISION_PASSES): push, then validate the pushed blades.
const COLLISION_PASSES: i32 = {{ collision_passes }};
// Words of the grid's header (collider_grid.GRID_HEADER_WORDS).
const GRID_HEADER_WORDS: u32 = {{ grid_header_words }}u;

// (first word, count) of the sphere list of the grid cell holding the root v0.
fn collider_cell_range(v0: vec3<f32>) -> vec2<u32> {
    let origin = vec2<f32>(bitcast<f32>(s_collider_grid[4]), bitcast<f32>(s_collider_grid[5]));
    let cell = grid_cell(v0, origin, bitcast<f32>(s_collider_grid[6]), s_collider_grid[0], s_collider_grid[1]);
    return vec2<u32>(s_collider_grid[GRID_HEADER_WORDS + 2u * cell], s_collider_grid[GRID_HEADER_WORDS + 2u * cell + 1u]);
}

// One push of a blade out of every sphere in reach in turn (collide_sphere); add sums
// |d|^2 (m^2) over the spheres, hit says whether any of them pushed.
fn collide_spheres(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, height: f32) -> Collision {
    var pushed = Collision(v2, 0.0, false);
    let list = collider_cell_range(v0);
    for (var k = 0u; k < list.y; k = k + 1u) {
        let sphere = s_colliders[s_collider_grid[list.x + k]];
        if (sphere_in_reach(v0, height, sphere)) {
            let col = collide_sphere(v0, v1, pushed.v2, sphere);
            pushed = Collision(col.v2, pushed.add + col.add, pushed.hit || col.hit);
        }
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
        let pushed = collide_spheres(v0, blade.v1, blade.v2, height);
        add = add + pushed.add;
        blade = validate_pushed(v0, blade.v1, blade.v2, up, height, pushed);
    }
    return Collided(blade.v1, blade.v2, add);
}
