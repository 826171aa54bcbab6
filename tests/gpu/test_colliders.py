"""Sphere colliders: validation, GPU vs reference, no penetration, the trampled trail."""

import numpy as np
import pytest
from traitlets import TraitError

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core.colliders import MAX_COLLIDERS, ColliderList

R = 1.0


# Fixtures blades, field and fresh (conftest): one field for the module, in calm air.
BLADES = dict(count=2048, size=10.0, seed=5)
FIELD_PARAMS = dict(wind_strength=0.0)


def _rel_err(gpu, cpu, b):
    return max((np.linalg.norm(gpu[k] - cpu[k], axis=1) / b.height).max() for k in ("v1", "v2"))


def _depth(state, ball):
    """Smallest distance / radius of the tips and curve midpoints from the ball's centre."""
    c = np.asarray(ball.center)
    m = 0.25 * state["v0"] + 0.5 * state["v1"] + 0.25 * state["v2"]
    tip = np.linalg.norm(state["v2"] - c, axis=1).min() / ball.radius
    mid = np.linalg.norm(m - c, axis=1).min() / ball.radius
    return tip, mid


# ----------------------------------------------------------------- validation


def test_sphere_collider_validates():
    ball = gw.SphereCollider(center=(1, 2, 3), radius=0.5)
    assert ball.center == (1.0, 2.0, 3.0) and ball.radius == 0.5
    for bad in (-1.0, 0.0, float("nan"), float("inf"), "big", None):
        with pytest.raises(TraitError, match="radius"):
            ball.radius = bad
    for bad in ((0, float("nan"), 0), (1, 2), (1, 2, 3, 4), "abc", (0, float("inf"), 0), None):
        with pytest.raises(TraitError, match="center"):
            ball.center = bad
    assert ball.center == (1.0, 2.0, 3.0) and ball.radius == 0.5  # old values kept
    with pytest.raises(TraitError, match="radius"):
        gw.SphereCollider(center=(0, 0, 0), radius=-2)
    with pytest.raises(TraitError, match="center"):
        gw.SphereCollider(center=(np.nan, 0, 0), radius=1)


def test_collider_list_limits(fresh):
    field = fresh
    balls = [gw.SphereCollider(center=(k, 5, 0), radius=0.1) for k in range(MAX_COLLIDERS + 1)]
    field.colliders.extend(balls[:MAX_COLLIDERS])  # MAX_COLLIDERS is fine
    field.step(2)
    with pytest.raises(ValueError, match=f"colliders: at most {MAX_COLLIDERS}"):
        field.colliders.append(balls[-1])
    with pytest.raises(ValueError, match="colliders"):
        field.colliders.insert(0, balls[-1])
    with pytest.raises(ValueError, match="colliders"):
        field.colliders += [balls[-1]]
    with pytest.raises(ValueError, match="colliders"):
        field.colliders = balls
    assert len(field.colliders) == MAX_COLLIDERS
    with pytest.raises(TypeError, match="SphereCollider"):
        field.colliders[0] = ((0, 0, 0), 1.0)
    field.colliders = balls[:3]  # assignment validates and keeps a ColliderList
    assert isinstance(field.colliders, ColliderList) and len(field.colliders) == 3
    # a plain list sneaked past the property is still checked when stepping
    list.extend(field.colliders, balls)  # past ColliderList's own checks
    with pytest.raises(ValueError, match="colliders"):
        field.step(1)
    field.colliders = ColliderList()


# ----------------------------------------------------------------- GPU vs reference


@pytest.mark.parametrize("steps", [1, 200])
def test_gpu_matches_reference_with_spheres(fresh, blades, steps):
    field = fresh
    field.params.wind_strength = 20.0
    balls = [
        gw.SphereCollider(center=(0.5, 1.2, -0.5), radius=1.2),
        gw.SphereCollider(center=(-3.0, 0.9, 2.0), radius=0.9),
        gw.SphereCollider(center=(3.0, 2.5, 3.0), radius=0.6),
    ]
    field.colliders.extend(balls)
    field.step(steps)
    gpu = field.read_state()
    cpu = ref.simulate(blades.rest_state(), field.params, steps, colliders=balls)
    err = _rel_err(gpu, cpu, blades)
    print(f"colliders, {steps} steps: max |gpu - ref| / h = {err:.2e}")
    assert err < 1e-4
    assert np.abs(gpu["collision"] - cpu["collision"]).max() < 1e-3
    assert (cpu["collision"] > 0).sum() > 20  # the spheres really hit blades
    assert gpu["collision"].max() <= 1.0


def _moving_crowd(rng, size):
    """40 balls: resting in the grass at random places (many straddle grid cells), overlapping
    pairs, one bigger than a grid cell, three at the field's edge and one far outside."""
    k = 40
    r = rng.uniform(0.25, 0.6, k)
    c = np.column_stack([rng.uniform(-size / 2, size / 2, k), 0.7 * r, rng.uniform(-size / 2, size / 2, k)])
    c[1::6] = c[0::6][: len(c[1::6])] + (0.3, 0.1, 0.2)  # overlapping pairs
    r[5], c[5] = 3.0, (0.0, 2.6, 0.0)  # bigger than a cell, resting on the grass
    c[6:9, 0] = size / 2 - 0.2  # at the edge: they leave the field as the crowd drifts +x
    c[9] = (40.0, 0.5, 0.0)  # far outside
    return np.column_stack([c, r])


def test_gpu_matches_reference_with_a_moving_crowd():
    """Dozens of balls (set_array) drifting across a field for 60 steps: the GPU, which tests
    only the balls listed in each blade's grid cell, equals the reference's loop over all."""
    from grasswidget.core.collider_grid import build_collider_grid, root_bounds

    rng = np.random.default_rng(21)
    size = 12.0
    blades = gw.Blades.on_plane(4096, size=size, seed=3, height=(0.4, 0.8), width=(0.03, 0.05))
    field = gw.GrassField(blades, gw.GrassParams(wind_strength=10.0))
    crowd = _moving_crowd(rng, size).astype(np.float32).astype(np.float64)
    cpu = blades.rest_state()
    drift = np.array([0.35, 0.0, 0.1, 0.0])
    for seg in range(6):
        balls = crowd + seg * drift
        field.colliders.set_array(balls)
        field.step(10)
        cpu = ref.simulate(cpu, field.params, 10, first_step=10 * seg, colliders=balls)
    gpu = field.read_state()
    err = np.max([np.linalg.norm(gpu[k] - cpu[k], axis=1) / blades.height for k in ("v1", "v2")], axis=0)
    print(f"crowd of {len(crowd)}: |gpu - ref| / h max {err.max():.2e}, 99th percentile {np.percentile(err, 99):.2e}")
    # float32 drift grows in the trampled blades (pushes switch on at a sphere's surface); a ball
    # missing from a blade's list would be off by centimetres (~1e-2 of h)
    assert np.percentile(err, 99) < 2e-5 and err.max() < 5e-4
    assert np.percentile(np.abs(gpu["collision"] - cpu["collision"]), 99) < 1e-4
    assert (cpu["collision"] > 0).mean() > 0.2  # the balls really trample the field
    # and the grid really prunes: several cells, a blade tests a fraction of the balls
    grid = build_collider_grid(balls, root_bounds(blades.v0), blades.height.max())
    assert grid.nx * grid.nz >= 16
    assert grid.cell_count[grid.cell_of(blades.v0)].mean() < 0.3 * len(crowd)
    assert field.simulation.collider_grid.nx * field.simulation.collider_grid.nz == grid.nx * grid.nz
    # the same run with one cell (every blade tests every ball, the paper's loop) is equal bit for bit
    field.simulation.max_grid_cells = 1
    field.reset()
    for seg in range(6):
        field.colliders.set_array(crowd + seg * drift)
        field.step(10)
    assert field.simulation.collider_grid.nx * field.simulation.collider_grid.nz == 1
    looped = field.read_state()
    for key in ("v1", "v2", "collision"):
        assert np.array_equal(looped[key], gpu[key]), key
    field.release()


def test_reset_zeroes_collision(fresh):
    fresh.colliders.append(gw.SphereCollider(center=(0, 1, 0), radius=1))
    fresh.step(20)
    assert fresh.read_state()["collision"].max() > 0
    fresh.reset()
    assert fresh.read_state()["collision"].max() == 0


# ----------------------------------------------------------------- rolling sphere


def test_rolled_sphere_leaves_a_trail_that_recovers(fresh, blades):
    """A ball (radius 2 m, larger than the blades, resting on the grass 0.1 m above
    the ground) rolls across the field at 2 m/s, then leaves."""
    field = fresh
    p = field.params
    settle = 240
    field.step(settle)
    radius, lift, speed = 2.0, 0.1, 2.0
    ball = gw.SphereCollider(center=(-7.0, radius + lift, 0.0), radius=radius)
    field.colliders.append(ball)
    xs = np.arange(-7.0, 7.0, speed * p.dt)
    under_seen, worst = 0, 9.0
    for k, x in enumerate(xs):
        ball.center = (x, radius + lift, 0.0)  # changes apply at the next step
        field.step(1)
        if k % 40 == 20:
            s = field.read_state()
            tip, mid = _depth(s, ball)
            worst = min(worst, tip, mid)
            assert tip > 0.97 and mid > 0.97, (k, tip, mid)
            under = np.linalg.norm((s["v0"] - ball.center)[:, [0, 2]], axis=1) < 0.5 * radius
            if under.any():
                under_seen += 1
                # (a blade already lying flat away from the ball may escape untouched)
                assert np.mean(s["collision"][under] > 0) > 0.75
                assert s["collision"][under].mean() > 0.2
    print(f"rolling ball: deepest tip/midpoint at {worst:.4f} of the radius")
    assert under_seen >= 10
    field.colliders.clear()  # the ball leaves
    after = field.read_state()
    n_roll = len(xs)

    # A calm field (no ball) run for the same number of steps.
    calm = ref.simulate(blades.rest_state(), p, settle + n_roll)
    # Blades the ball let go of in the last ~2 s.
    trail = (np.abs(blades.v0[:, 2]) < 1.0) & (blades.v0[:, 0] > 1.0) & (blades.v0[:, 0] < 4.5)
    assert trail.sum() > 50

    def rise(s):  # tip height over blade height: 1 upright, 0 flat
        return (np.sum((s["v2"] - s["v0"]) * s["up"], axis=1) / blades.height)[trail]

    print("trail: eta", after["collision"][trail].mean(), "rise", rise(after).mean(), "calm", rise(calm).mean())
    assert after["collision"][trail].mean() > 0.2
    assert rise(after).mean() < rise(calm).mean() - 0.2  # trampled
    # Still down half a second later (collision strength weakens the recovery) ...
    field.step(60)
    calm = ref.simulate(calm, p, 60, first_step=settle + n_roll)
    half = field.read_state()
    print("after 0.5 s: rise", rise(half).mean(), "calm", rise(calm).mean())
    assert rise(half).mean() < rise(calm).mean() - 0.15
    # ... while without the memory (eta gone at once) blades spring back sooner.
    quick = p.copy()
    quick.collision_fade = 100.0
    start = {k: np.asarray(v, np.float64) for k, v in after.items()}
    start["collision"] = np.zeros(len(blades))
    nomem = ref.simulate(start, quick, 60, first_step=settle + n_roll)
    print("after 0.5 s without memory: rise", rise(nomem).mean())
    assert rise(nomem).mean() > rise(half).mean() + 0.1
    # After the strength has faded (1 / collision_fade s) and 2 s more: back to the calm pose.
    more = int((1.0 / p.collision_fade + 2.0) / p.dt)
    field.step(more)
    calm = ref.simulate(calm, p, more, first_step=settle + n_roll + 60)
    back = field.read_state()
    assert back["collision"].max() == 0
    err = (np.linalg.norm(back["v2"] - calm["v2"], axis=1) / blades.height).max()
    print("back to calm: max |v2 - calm| / h", err)
    assert err < 1e-3


def test_set_array_balls_are_drawn_and_follow_the_crowd():
    """The set_array spheres are drawn (an instanced mesh sized to the crowd): more balls
    change more pixels, a crowd past the first 16 instances shows too, and an empty array
    gives the picture without balls back. Balls above the grass; render only: the grass
    does not move."""
    scene = gw.GrassScene(gw.Blades.on_plane(2048, size=10.0, seed=5), size=(160, 120))
    try:
        bare = scene.render().astype(int)
        rng = np.random.default_rng(4)

        def changed(k):
            xz = rng.uniform(-4.0, 4.0, (k, 2))
            scene.colliders.set_array(np.c_[xz[:, 0], np.full(k, 3.2), xz[:, 1], np.full(k, 0.5)])
            return (np.abs(scene.render().astype(int) - bare).max(axis=2) > 12).mean()

        few, many = changed(8), changed(40)
        assert 0.002 < few < many
        assert changed(0) == 0.0
    finally:
        scene.release()
