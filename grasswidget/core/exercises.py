"""The CIS 565 grass assignment as exercises (pure: NumPy and text, no GPU).

Each exercise names stock functions of ``shaders/blade_math.wgsl`` that a student
writes again (their NumPy twins in :mod:`grasswidget.core.reference` are the
answer key), and holds the task (text with the paper's equations), the starter
code, the teacher's solution and the test cases the grader
(:mod:`grasswidget.tools.grading`) runs through the real simulation and culling
passes. ``gw.exercise(name)`` (:mod:`grasswidget.notebook.exercise`) is the face.

==============  ==========================================================  ==========
exercise        functions                                                   pass
==============  ==========================================================  ==========
``forces``      environmental_gravity, front_gravity, wind_force,           simulation
                integrate_tip (recovery)
``validation``  validate_ground, validate_v1, validate_length               simulation
``culling``     orientation_cull, frustum_cull, distance_cull               culling
==============  ==========================================================  ==========

Cases are fixed (seeded): the same blades, parameters and cameras every run, chosen
so that every branch of every function matters: calm air, gusts (wave and noise
wind), gravity towards a point, a ball (collision strength lowers the recovery),
tips pushed under the ground, blades lying flat, tilted ground normals, very stiff
blades; cameras looking over the field, low and edge-on, away (half the field
behind), far, with the eye 7.5 cm from a blade's tip (nearer than the near plane: the
depth test's 0 <= z decides) and 110 m away (the far half of the field past the far
plane: z <= w decides).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from . import reference as ref
from .blades import Blades
from .enums import GravityMode
from .wgsl_overrides import strip_comments
from ..errors import GrassValueError

__all__ = ["ExerciseFunction", "ExerciseSpec", "SimulationCase", "CullingCase", "EXERCISES", "exercise_spec",
           "step_trace", "function_io", "call_paths", "pass_source", "PASS_FILES", "function_calls", "cull_io", "cull_details", "cull_margin",
           "near_cull_threshold", "SIM_TOLERANCE", "VARIANTS", "exercise_variant", "reference_examples"]

#: A simulated function passes when every blade's v1 and v2 after one step are within this
#: many blade heights of the reference (float32 rounding of one step is about 1e-7).
SIM_TOLERANCE = 2e-5


@dataclass(frozen=True)
class ExerciseFunction:
    """One function a student writes: ``name`` (the stock WGSL function and its NumPy
    twin), ``label`` (what it computes, in words), ``equation`` (the paper's, Markdown),
    ``units``."""

    name: str
    label: str
    equation: str
    units: str


@dataclass(frozen=True)
class SimulationCase:
    """One step of the simulation pass from a given state: ``name``, ``description``,
    ``state`` (a state dict of N blades: v0, v1, v2, up, height, width, orientation,
    stiffness, collision), ``params`` (GrassParams trait values), ``spheres`` ((K, 4)
    centre and radius, m) and ``step_index`` (the step's time is step_index * dt)."""

    name: str
    description: str
    state: dict
    params: dict
    spheres: np.ndarray
    step_index: int = 0


@dataclass(frozen=True)
class CullingCase:
    """One culling pass: ``name``, ``description``, ``state`` (as above), ``params``
    (culling trait values), and the camera: ``position``, ``target`` (m), ``fov_deg``
    (vertical), ``size`` (pixels)."""

    name: str
    description: str
    state: dict
    params: dict
    position: tuple
    target: tuple
    fov_deg: float = 45.0
    size: tuple = (96, 72)


@dataclass(frozen=True)
class ExerciseSpec:
    """An exercise: ``name``, ``title``, ``kind`` ("simulation" or "culling"),
    ``functions`` (ExerciseFunction, in the order the task presents them), ``task``
    (Markdown), ``starter`` and ``solution`` (WGSL), ``cases`` (a callable returning the
    fixed cases) and ``variant`` ("equations": the task gives the paper's equations; "derive":
    the physics in words, see :func:`exercise_variant`)."""

    name: str
    title: str
    kind: str
    functions: tuple
    task: str
    starter: str
    solution: str
    make_cases: object = field(repr=False)
    variant: str = "equations"

    @property
    def names(self) -> tuple:
        """The names of the functions the student writes."""
        return tuple(f.name for f in self.functions)

    def function(self, name) -> ExerciseFunction:
        for f in self.functions:
            if f.name == name:
                return f
        raise GrassValueError(f"name must be one of {', '.join(self.names)}; got {name!r}")

    def cases(self) -> list:
        """The fixed test cases (a new list of new arrays each call)."""
        return self.make_cases()


# ------------------------------------------------------------------ cases


def _blades(n, seed, size=6.0, tilt=0.0):
    b = Blades.on_plane(n, size=size, seed=seed)
    if tilt:
        rng = np.random.default_rng(seed + 100)
        up = np.array([0.0, 1.0, 0.0]) + rng.uniform(-tilt, tilt, (n, 3)) * np.array([1.0, 0.0, 1.0])
        b = Blades(v0=b.v0, up=up, orientation=b.orientation, height=b.height, width=b.width, stiffness=b.stiffness)
    return b


def _bent(blades, seed, lean=(0.1, 0.9), under=0.0, valid=True):
    """A state whose tips lean by lean * h in random directions of the tangent plane
    (validated unless ``valid`` is False); ``under`` > 0 pushes every other tip that
    many heights below the ground."""
    rng = np.random.default_rng(seed)
    s = blades.rest_state()
    v0, up, h = (s[k].astype(np.float64) for k in ("v0", "up", "height"))
    basis_t1 = ref.width_direction(up, rng.uniform(0, 2 * np.pi, len(h)))
    lean_by = rng.uniform(*lean, len(h))
    v2 = v0 + up * (h * np.sqrt(np.maximum(1 - lean_by ** 2, 0.05)))[:, None] + basis_t1 * (h * lean_by)[:, None]
    if under:
        v2[::2] -= up[::2] * (h[::2] * (under + np.sqrt(np.maximum(1 - lean_by[::2] ** 2, 0.05))))[:, None]
    if valid:
        v1, v2 = ref.validate_state(v0, v2, up, h)
    else:
        v1 = ref.validate_v1(v0, ref.validate_ground(v0, v2, up), up, h)
    s["v1"], s["v2"] = v1.astype(np.float32), v2.astype(np.float32)
    s["collision"] = np.zeros(len(h), np.float32)
    return s


def _simulation_cases():
    n = 32
    flat = _blades(n, 11)
    tilted = _blades(n, 12, tilt=0.6)
    none = np.zeros((0, 4))
    ball_state = _bent(flat, 5)
    ball_state["collision"] = np.linspace(0.0, 0.95, n).astype(np.float32)
    return [
        SimulationCase("calm", "no wind: gravity, front gravity and recovery on leaning blades",
                       _bent(flat, 1), dict(wind_strength=0.0), none),
        SimulationCase("gusts", "a strong travelling wave of wind, 0.7 s in",
                       _bent(flat, 2), dict(wind_field="wave", wind_strength=40.0, wind_direction=30.0), none, 84),
        SimulationCase("noise gusts on a slope", "noise wind on blades whose ground normals tilt",
                       _bent(tilted, 3), dict(wind_field="noise", wind_strength=60.0, wind_direction=-70.0,
                                              gravity_direction=(0.2, -1.0, 0.1)), none, 30),
        SimulationCase("point gravity", "gravity towards a point under the field, front gravity 0.6",
                       _bent(tilted, 4), dict(gravity_mode="point", gravity_center=(1.0, -8.0, 2.0), gravity=14.0,
                                              front_gravity=0.6, wind_strength=10.0), none, 12),
        SimulationCase("a ball", "a ball among the blades; collision strength 0 to 0.95 weakens the recovery",
                       ball_state, dict(wind_strength=8.0), np.array([[0.0, 1.0, 0.0, 1.6]]), 5),
        SimulationCase("pushed under the ground", "every other tip starts below the ground",
                       _bent(flat, 6, under=0.3, valid=False), dict(wind_strength=20.0), none, 40),
        SimulationCase("lying flat", "tips pulled out further than the blade is tall (l_proj > h)",
                       _bent(tilted, 7, lean=(1.1, 1.8), valid=False), dict(wind_strength=5.0, stiffness_scale=3.0),
                       none, 7),
        SimulationCase("stiff", "stiffness x 20: s * dt > 1, the recovery taken at the end of the step",
                       _bent(flat, 8, lean=(0.5, 0.95)), dict(stiffness_scale=20.0, wind_strength=25.0), none, 3),
    ]


def _culling_cases():
    blades = Blades.on_plane(400, size=24.0, seed=21)
    state = _bent(blades, 9, lean=(0.0, 0.6))
    base = dict(cull_orientation_threshold=0.9, cull_frustum_tolerance=0.5, cull_distance_max=30.0, cull_buckets=8)
    return [
        CullingCase("overview", "over the whole field from above and behind", state, dict(base),
                    (0.0, 14.0, 20.0), (0.0, 0.0, 0.0)),
        CullingCase("low, edge-on", "eye at blade height: many blades seen edge-on", state,
                    dict(base, cull_orientation_threshold=0.7), (0.0, 1.0, 14.0), (0.0, 1.0, 0.0)),
        CullingCase("looking away", "standing in the field looking at a corner: half of it behind the camera",
                    state, dict(base, cull_frustum_tolerance=0.1), (0.0, 3.0, 0.0), (12.0, 1.0, 12.0), 40.0),
        CullingCase("far", "from far away: distance thins the field", state,
                    dict(base, cull_distance_max=45.0, cull_buckets=16), (0.0, 8.0, 38.0), (0.0, 0.0, 0.0), 30.0),
        CullingCase("eye at a tip", "the eye 7.5 cm from a blade's tip, nearer than the near plane (0.1 m): "
                    "0 <= z decides", state, dict(base), *_eye_at_tip(state)),
        CullingCase("past the far plane", "110 m away: the far half of the field lies beyond the far plane "
                    "(100 m): z <= w decides", state, dict(base), (0.0, 4.0, 112.0), (0.0, 0.0, 0.0), 12.0),
    ]


def _eye_at_tip(state, gap=0.075):
    """(position, target) of a camera looking level along the ground, ``gap`` m behind the
    tip v2 of the leaning blade nearest the field's centre: the tip lies between the eye
    and the near plane (0.1 m), its root and midpoint far below the view."""
    v0, v1, v2 = (np.asarray(state[k], np.float64) for k in ("v0", "v1", "v2"))
    mid = 0.25 * v0 + 0.5 * v1 + 0.25 * v2
    drop = v2[:, 1] - mid[:, 1]
    k = int(np.argmin(np.linalg.norm(v0[:, [0, 2]], axis=1) + 10.0 * (drop < 0.4)))
    eye = v2[k] - np.array([0.0, 0.0, -gap])
    return tuple(eye), tuple(eye + np.array([0.0, 0.0, -5.0]))


# ------------------------------------------------------------------ the reference, step by step


def step_trace(state, params, t, spheres=None) -> dict:
    """Every intermediate value of one simulation step (reference.simulate_step's chain),
    per blade: inputs and outputs of each exercise function. Keys: ``g_env``, ``f``,
    ``g_front``, ``gravity``, ``W`` (wind field at v0), ``wind`` (wind force),
    ``s_eff``, ``iv2``, ``accel``, ``moved`` (integrate_tip), ``v2_ground``, ``v1_lean``,
    ``v1``, ``v2`` (validate_length), ``v1_out``, ``v2_out`` (after collisions) and
    ``collisions`` (a list, one dict per collision pass: ``hit`` (bool per blade: the pass
    validated the blade again), ``pushed`` (the tip the spheres pushed), ``v2_ground``,
    ``v1_lean``, ``v1``, ``v2``: the validation of that pass)."""
    v0, up, v2 = (np.asarray(state[k], np.float64) for k in ("v0", "up", "v2"))
    h = np.asarray(state["height"], np.float64)
    eta = ref.fade_collision(np.asarray(state.get("collision", np.zeros(len(h))), np.float64), params.collision_fade,
                             params.dt)
    s_eff = ref.effective_stiffness(np.asarray(state["stiffness"], np.float64) * params.stiffness_scale, eta)
    t1 = ref.width_direction(up, state["orientation"])
    f = ref.front_direction(up, t1)
    g_env = ref.environmental_gravity(v0, params.gravity_mode, params.gravity_direction, params.gravity_center,
                                      params.gravity)
    g_front = ref.front_gravity(g_env, f, params.front_gravity)
    W = ref.wind_field(v0, t, params)
    wind = ref.wind_force(W, v0, v2, up, h)
    iv2 = v0 + up * h[:, None]
    accel = g_env + g_front + wind
    moved = ref.integrate_tip(v2, iv2, s_eff, accel, params.dt)
    v2g = ref.validate_ground(v0, moved, up)
    v1_lean = ref.validate_v1(v0, v2g, up, h)
    v1, v2n = ref.validate_length(v0, v1_lean, v2g, h)
    spheres = np.zeros((0, 4)) if spheres is None else np.asarray(spheres, np.float64).reshape(-1, 4)
    v1_out, v2_out, _ = ref.collision_passes(v0, v1, v2n, up, h, spheres)
    collisions, c1, c2 = [], v1, v2n
    if len(spheres):
        for _ in range(ref.COLLISION_PASSES):  # collision_passes step by step: what each validation is handed
            pushed, _, hit = ref.collide_spheres(v0, c1, c2, h, spheres)
            pg = ref.validate_ground(v0, pushed, up)
            pl = ref.validate_v1(v0, pg, up, h)
            p1, p2 = ref.validate_length(v0, pl, pg, h)
            collisions.append(dict(hit=np.asarray(hit, bool), pushed=pushed, v2_ground=pg, v1_lean=pl, v1=p1, v2=p2))
            c1, c2 = np.where(hit[:, None], p1, c1), np.where(hit[:, None], p2, c2)
    return dict(v0=v0, up=up, height=h, v2_in=v2, g_env=g_env, f=f, g_front=g_front, gravity=g_env + g_front, W=W,
                wind=wind, s_eff=s_eff, iv2=iv2, accel=accel, moved=moved, v2_ground=v2g, v1_lean=v1_lean, v1=v1,
                v2=v2n, v1_out=v1_out, v2_out=v2_out, collisions=collisions)


def function_io(name, trace, params, k) -> tuple:
    """(inputs, reference output) of exercise function ``name`` for blade ``k`` in one
    step (``trace`` from :func:`step_trace`): the arguments the simulation pass gives it,
    by parameter name, and what its NumPy twin returns."""
    T = {key: (v[k] if isinstance(v, np.ndarray) and v.ndim else v) for key, v in trace.items()}
    if name == "environmental_gravity":
        mode = int(GravityMode.from_label(params.gravity_mode))
        return (dict(v0=T["v0"], gravity_mode=mode, direction=params.gravity_direction, center=params.gravity_center,
                     magnitude=params.gravity), T["g_env"])
    if name == "front_gravity":
        return dict(g_env=T["g_env"], f=T["f"], factor=params.front_gravity), T["g_front"]
    if name == "wind_force":
        return dict(W=T["W"], v0=T["v0"], v2=T["v2_in"], up=T["up"], height=T["height"]), T["wind"]
    if name == "integrate_tip":
        return (dict(v2=T["v2_in"], iv2=T["iv2"], stiffness=T["s_eff"], accel=T["accel"], dt=params.dt),
                T["moved"])
    if name == "validate_ground":
        return dict(v0=T["v0"], v2=T["moved"], up=T["up"]), T["v2_ground"]
    if name == "validate_v1":
        return dict(v0=T["v0"], v2=T["v2_ground"], up=T["up"], height=T["height"]), T["v1_lean"]
    if name == "validate_length":
        return (dict(v0=T["v0"], v1=T["v1_lean"], v2=T["v2_ground"], height=T["height"]),
                {"v1": T["v1"], "v2": T["v2"]})
    raise GrassValueError(f"name must be a simulated exercise function; got {name!r}")


_VALIDATED = ("validate_ground", "validate_v1", "validate_length")


def function_calls(name, trace, params, k) -> list:
    """Every call the simulation pass makes of exercise function ``name`` for blade ``k``
    in one step (``trace`` from :func:`step_trace`), in order: a list of (where, inputs,
    reference output). The forces are called once ("the step"); the validation functions
    once in the step and again in each collision pass that pushed the blade ("collision
    pass 1", ...: the ball moved the tip, the pass validates it again)."""
    inputs, reference = function_io(name, trace, params, k)
    calls = [("the step", inputs, reference)]
    if name not in _VALIDATED:
        return calls
    v0, up, h = trace["v0"][k], trace["up"][k], trace["height"][k]
    for p, c in enumerate(trace["collisions"]):
        if not c["hit"][k]:
            continue
        where = f"collision pass {p + 1} (a sphere pushed the tip; validated again)"
        if name == "validate_ground":
            calls.append((where, dict(v0=v0, v2=c["pushed"][k], up=up), c["v2_ground"][k]))
        elif name == "validate_v1":
            calls.append((where, dict(v0=v0, v2=c["v2_ground"][k], up=up, height=h), c["v1_lean"][k]))
        else:
            calls.append((where, dict(v0=v0, v1=c["v1_lean"][k], v2=c["v2_ground"][k], height=h),
                          {"v1": c["v1"][k], "v2": c["v2"][k]}))
    return calls


def cull_io(name, state, params, view_proj, cam_pos, k) -> tuple:
    """(inputs, reference output) of culling function ``name`` for blade ``k`` under a
    camera (``view_proj``: 4x4 world to clip, ``cam_pos``)."""
    v0, v1, v2, up = (np.asarray(state[key][k], np.float64) for key in ("v0", "v1", "v2", "up"))
    if name == "orientation_cull":
        t1 = ref.width_direction(up[None], np.asarray([state["orientation"][k]]))[0]
        i = dict(v0=v0, t1=t1, cam_pos=cam_pos, threshold=params.cull_orientation_threshold)
        return i, bool(ref.orientation_cull(v0[None], t1[None], cam_pos, i["threshold"])[0])
    if name == "frustum_cull":
        i = dict(v0=v0, v1=v1, v2=v2, view_proj=np.round(view_proj, 4), tol=params.cull_frustum_tolerance)
        return i, bool(ref.frustum_cull(v0[None], v1[None], v2[None], view_proj, i["tol"])[0])
    if name == "distance_cull":
        i = dict(v0=v0, up=up, cam_pos=cam_pos, id=k, buckets=params.cull_buckets, d_max=params.cull_distance_max)
        return i, bool(ref.distance_cull(v0[None], up[None], cam_pos, np.array([k]), params.cull_buckets,
                                         params.cull_distance_max)[0])
    raise GrassValueError(f"name must be a culling exercise function; got {name!r}")


_PLANES = ("x < -(w + tol)", "x > w + tol", "y < -(w + tol)", "y > w + tol", "z < 0 (in front of the near plane)",
           "z > w (beyond the far plane)")


def _clip_points(state, view_proj, k=None):
    """The three points frustum_cull projects (v0, the curve's midpoint m, v2) in clip space:
    {name: (N, 4)} or, for one blade ``k``, {name: (4,)}."""
    sel = slice(None) if k is None else slice(k, k + 1)
    v0, v1, v2 = (np.asarray(state[key][sel], np.float64) for key in ("v0", "v1", "v2"))
    vp = np.asarray(view_proj, np.float64)
    out = {}
    for label, p in (("v0", v0), ("m", 0.25 * v0 + 0.5 * v1 + 0.25 * v2), ("v2", v2)):
        c = np.concatenate([p, np.ones((len(p), 1))], 1) @ vp.T
        out[label] = c if k is None else c[0]
    return out


def _outside_by(c, tol):
    """How far clip point(s) ``c`` lie outside each plane (N, 6): > 0 outside that plane."""
    c = np.atleast_2d(c)
    lim = c[:, 3] + tol
    return np.stack([-c[:, 0] - lim, c[:, 0] - lim, -c[:, 1] - lim, c[:, 1] - lim, -c[:, 2], c[:, 2] - c[:, 3]], 1)


def cull_details(name, state, params, view_proj, cam_pos, k) -> dict:
    """What decides culling test ``name`` for blade ``k``, in the reference's terms (for a
    report): orientation: ``|dir · t1|`` and the threshold; frustum: the clip coordinates
    (x, y, z, w) of v0, m and v2 and, for each, the plane it is outside ("inside" when
    none); distance: ``d`` (m, on the ground), ``bucket`` (id % buckets), ``keep``
    (⌈buckets · max(1 − d / d_max, 0)⌉) and the rule."""
    v0, up = (np.asarray(state[key][k], np.float64) for key in ("v0", "up"))
    d = v0 - np.asarray(cam_pos, np.float64)
    if name == "orientation_cull":
        t1 = ref.width_direction(up[None], np.asarray([state["orientation"][k]]))[0]
        o = abs(float(np.dot(d / np.linalg.norm(d), t1)))
        return {"|normalize(v0 - cam_pos) · t1|": o, "threshold": params.cull_orientation_threshold,
                "rule": "cull when the first is greater"}
    if name == "frustum_cull":
        out = {}
        for label, c in _clip_points(state, view_proj, k).items():
            by = _outside_by(c, params.cull_frustum_tolerance)[0]
            where = "inside" if (by <= 0).all() else "outside: " + _PLANES[int(np.argmax(by))]
            out[f"{label} in clip space (x, y, z, w)"] = f"{format_clip(c)}  {where}"
        out["rule"] = (f"inside when |x| <= w + tol, |y| <= w + tol, 0 <= z <= w (tol = {params.cull_frustum_tolerance:g});"
                       " cull when all three are outside")
        return out
    if name == "distance_cull":
        dg = float(np.linalg.norm(d - up * np.dot(d, up)))
        b, d_max = int(params.cull_buckets), float(params.cull_distance_max)
        keep = int(np.ceil(b * max(1.0 - dg / d_max, 0.0)))
        return {"d (on the ground, m)": dg, "d_max": d_max, "bucket (id % buckets)": f"{k % b} of {b}",
                "keep": f"{keep} of every {b}", "rule": f"cull when bucket >= keep: {k % b} >= {keep} is "
                                                        f"{'true' if k % b >= keep else 'false'}"}
    raise GrassValueError(f"name must be a culling exercise function; got {name!r}")


def format_clip(c) -> str:
    """A clip-space point as ``(x, y, z, w)`` with 4 significant digits."""
    return "(" + ", ".join(f"{float(v):.4g}" for v in c) + ")"


def cull_margin(name, state, params, view_proj, cam_pos) -> np.ndarray:
    """(N,) how clearly the reference decides test ``name`` for each blade (larger: further
    from its threshold): the grader shows the wrongly decided blade with the largest margin."""
    v0, up = (np.asarray(state[k], np.float64) for k in ("v0", "up"))
    d = v0 - np.asarray(cam_pos, np.float64)
    if name == "orientation_cull":
        t1 = ref.width_direction(up, state["orientation"])
        return np.abs(np.abs(np.sum(d / np.linalg.norm(d, axis=1)[:, None] * t1, axis=1))
                      - params.cull_orientation_threshold)
    if name == "frustum_cull":
        worst = None
        for c in _clip_points(state, view_proj).values():
            by = _outside_by(c, params.cull_frustum_tolerance).max(axis=1) / np.maximum(np.abs(c[:, 3]), 1.0)
            worst = by if worst is None else np.minimum(worst, by)
        return np.abs(worst)
    if name == "distance_cull":
        dproj = np.linalg.norm(d - up * np.sum(d * up, axis=1)[:, None], axis=1)
        x = params.cull_buckets * np.maximum(1 - dproj / params.cull_distance_max, 0)
        bucket = np.arange(len(v0)) % params.cull_buckets
        return np.abs(bucket + 0.5 - x)
    raise GrassValueError(f"name must be a culling exercise function; got {name!r}")


def near_cull_threshold(name, state, params, view_proj, cam_pos, eps=1e-4) -> np.ndarray:
    """bool (N,): blades within ``eps`` of test ``name``'s threshold, where float32
    rounding may decide either way (left out of the comparison)."""
    v0, v1, v2, up = (np.asarray(state[k], np.float64) for k in ("v0", "v1", "v2", "up"))
    d = v0 - np.asarray(cam_pos, np.float64)
    if name == "orientation_cull":
        t1 = ref.width_direction(up, state["orientation"])
        o = np.abs(np.sum(d / np.linalg.norm(d, axis=1)[:, None] * t1, axis=1))
        return np.abs(o - params.cull_orientation_threshold) < eps
    if name == "frustum_cull":
        near = np.zeros(len(v0), bool)
        for p in (v0, 0.25 * v0 + 0.5 * v1 + 0.25 * v2, v2):
            c = np.concatenate([p, np.ones((len(p), 1))], 1) @ np.asarray(view_proj, np.float64).T
            lim = c[:, 3] + params.cull_frustum_tolerance
            for val in (np.abs(c[:, 0]) - lim, np.abs(c[:, 1]) - lim, c[:, 2], c[:, 2] - c[:, 3]):
                near |= np.abs(val) < eps * np.maximum(1.0, np.abs(c[:, 3]))
        return near
    if name == "distance_cull":
        dproj = np.linalg.norm(d - up * np.sum(d * up, axis=1)[:, None], axis=1)
        x = params.cull_buckets * np.maximum(1 - dproj / params.cull_distance_max, 0)
        return np.abs(x - np.round(x)) < eps * params.cull_buckets
    raise GrassValueError(f"name must be a culling exercise function; got {name!r}")


# ------------------------------------------------------------------ the pass around the functions

#: The pass each kind of exercise runs the student's functions in.
PASS_FILES = {"simulation": "simulate.wgsl", "culling": "cull.wgsl"}


def _function_spans(text) -> dict:
    """{name: (start of ``fn``, one past the closing brace)} of the module-scope functions of
    WGSL ``text`` (comments already blanked), entry points with ``@builtin(...)`` parameters included."""
    spans, pos = {}, 0
    head = re.compile(r"\bfn\s+(\w+)\s*\(")
    while True:
        m = head.search(text, pos)
        if not m:
            return spans
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            i += 1
        i = text.find("{", i)
        if i < 0:
            return spans
        depth, j = 1, i + 1
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        spans[m.group(1)] = (m.start(), j)
        pos = j


def call_paths(wgsl: str, entry: str, targets) -> list:
    """Every call path in WGSL ``wgsl`` from function ``entry`` to each function of
    ``targets``: a list of tuples of function names (entry first, a target last), in the
    order of ``targets``; paths through a target stop there."""
    text = strip_comments(wgsl)
    spans = _function_spans(text)
    calls = {name: [c for c in dict.fromkeys(re.findall(r"\b(\w+)\s*\(", text[a:b][text[a:b].find("{"):]))
                    if c in spans and c != name] for name, (a, b) in spans.items()}
    found = []

    def walk(path):
        for c in calls.get(path[-1], []):
            if c in path:
                continue
            if c in targets:
                found.append(path + (c,))
            else:
                walk(path + (c,))

    walk((entry,))
    order = {t: k for k, t in enumerate(targets)}
    return sorted(found, key=lambda p: (order[p[-1]], len(p)))


def pass_source(spec) -> str:
    """The WGSL a student needs to see around their functions: the call paths from the
    pass's entry point (``main`` of ``simulate.wgsl`` or ``cull.wgsl``) to each function of
    exercise ``spec``, then the source of every function on those paths (the student's
    functions themselves left out), each headed by the shader file it comes from."""
    from .shader_files import read_shader, render_wgsl, shader_names

    pass_file = PASS_FILES[spec.kind]
    wgsl = render_wgsl(pass_file)
    paths = call_paths(wgsl, "main", spec.names)
    text = strip_comments(wgsl)
    spans = _function_spans(text)
    home = {}
    for name in [pass_file] + shader_names():  # the file defining each function (as stored: includes not expanded)
        for fn in _function_spans(strip_comments(read_shader(name))):
            home.setdefault(fn, name)
    shown = [f for f in dict.fromkeys(f for p in paths for f in p) if f not in spec.names]
    lines = [f"// How the {spec.kind} pass ({pass_file}) reaches your functions, from its entry point `main`:"]
    lines += ["//   " + " -> ".join(p) for p in paths]
    lines.append("// Each function on these paths, as shipped (your functions are where they are called):")
    for f in shown:
        a, b = spans[f]
        head = wgsl.rfind("\n", 0, wgsl.rfind("\n", 0, a))  # the entry point's attributes on the line before
        if wgsl[head + 1:a].lstrip().startswith("@"):
            a = head + 1
        lines.append(f"\n// ---- {f} (from {home.get(f, pass_file)})")
        lines.append(wgsl[a:b])
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ the exercises

_UNITS = ("Units: metres (positions), seconds (`dt`), m/s² (accelerations: gravity, wind), 1/s² "
          "(stiffness `s`). `up` is the blade's unit ground normal, `height` its length h.")

_FORCES_TASK = r"""
### Exercise "forces": the three forces on a blade tip (paper section 5.1)

Each blade is a quadratic Bézier curve v0 → v1 → v2; the simulation moves the tip guide **v2**
(v1 follows from the state validation, the next exercise). Write four WGSL functions; the
simulation pass (`simulate.wgsl`) calls them once per blade and step:

1. **Environmental gravity** (eq. 1) — `environmental_gravity(v0, gravity_mode, direction, center, magnitude) -> vec3<f32>`:
   gE = normalize(direction) · magnitude; when `gravity_mode` is 1 ("point"; 0 is "direction"), gravity
   pulls towards a point: gE = normalize(center − v0) · magnitude (0 for a root exactly at `center`).
2. **Front gravity** (eq. 2) — `front_gravity(g_env, f, factor) -> vec3<f32>`: gF = factor · |gE| · f,
   f the blade's front direction (unit). The paper uses factor ¼. Gravity is g = gE + gF.
3. **Wind** (eq. 3-5) — `wind_force(W, v0, v2, up, height) -> vec3<f32>`: W is the wind field at the root.
   Directional alignment fd = 1 − |normalize(W) · normalize(v2 − v0)|; height ratio fr = ((v2 − v0) · up) / h;
   w = W · fd · fr. No wind (|W| = 0) gives no force.
4. **Recovery and the step** (eq. 4 and the update of 5.1) — `integrate_tip(v2, iv2, stiffness, accel, dt) -> vec3<f32>`:
   the recovery r = (iv2 − v2) · s pulls the tip back to its rest position iv2 = v0 + up · h.
   The paper's explicit update v2 += (r + g + w) · dt oscillates for stiff blades, so take the recovery at the
   end of the step (semi-implicit): v2' = v2 + dt · (accel + s · (iv2 − v2)) / (1 + s · dt), with accel = g + w.

The grader runs your functions inside the real simulation pass, one at a time (the others stock), one step of
`dt` on fixed blades and compares the blades with the NumPy reference (`grasswidget.core.reference`).
"""

_VALIDATION_TASK = r"""
### Exercise "validation": keep every blade a valid blade (paper section 5.2)

After the forces move the tip v2, three corrections keep the blade in shape. The simulation pass calls
them in this order (`validate_state` in `blade_math.wgsl`):

1. **Above the ground** — `validate_ground(v0, v2, up) -> vec3<f32>`: a tip below the blade's ground plane goes
   back onto it: v2 ← v2 − up · min(up · (v2 − v0), 0).
2. **v1 from the lean** (eq. 6-7) — `validate_v1(v0, v2, up, height) -> vec3<f32>`:
   l_proj = |v2 − v0 − up · ((v2 − v0) · up)|, v1 = v0 + h · up · max(1 − l_proj / h, 0.05 · max(l_proj / h, 1)).
3. **Length h** (eq. 8-10) — `validate_length(v0, v1, v2, height) -> Guides` (`struct Guides { v1: vec3<f32>, v2: vec3<f32> }`):
   the curve's length L = (2 L0 + L1) / 3 with L0 = |v2 − v0|, L1 = |v2 − v1| + |v1 − v0| (n = 2);
   r = h / L; v1' = v0 + r (v1 − v0); v2' = v1' + r (v2 − v1). The stock `curve_length(v0, v1, v2)` exists;
   you may call it or write L out.

The grader runs each function alone in the real simulation pass and compares v1 and v2 with the reference.
"""

_CULLING_TASK = r"""
### Exercise "culling": three tests that skip blades before drawing (paper section 6)

The culling pass (`cull.wgsl`) runs every frame, one thread per blade, and draws only the blades no test
culls. Each function returns `true` to **cull** (skip) the blade:

1. **Orientation** — `orientation_cull(v0, t1, cam_pos, threshold) -> bool`: a blade seen edge-on covers
   almost no pixels: cull when |normalize(v0 − cam_pos) · t1| > threshold (t1: the blade's unit width direction;
   default threshold 0.9).
2. **View frustum** — `frustum_cull(v0, v1, v2, view_proj, tol) -> bool`: project v0, the curve's midpoint
   m = ¼ v0 + ½ v1 + ¼ v2 and v2 to clip space (p' = view_proj · (p, 1)); a point is inside when
   |x| ≤ w + tol, |y| ≤ w + tol and 0 ≤ z ≤ w (WebGPU's depth range). Cull when all three are outside.
   The stock helper `clip_outside(clip, tol) -> bool` exists; you may use it or write the test out.
3. **Distance** — `distance_cull(v0, up, cam_pos, id, buckets, d_max) -> bool`: thin the field with the
   distance on the ground d = |v0 − c − up · ((v0 − c) · up)| (c = cam_pos): of every `buckets` blades
   (by `id % buckets`), keep ⌈buckets · max(1 − d / d_max, 0)⌉: cull when f32(id % buckets) ≥ that number.

The grader renders fixed cameras with one test switched on at a time, with your function in the real
culling pass, and compares which blades are drawn with the reference. Units: metres; `view_proj` maps world
to clip space.
"""

_FORCES_STARTER = """\
// Exercise "forces": fill in the four functions (keep their signatures).
// Vectors in metres, accelerations in m/s^2, stiffness in 1/s^2, dt in s.

// Environmental gravity gE (eq. 1). gravity_mode: 0 = along direction, 1 = towards center.
fn environmental_gravity(v0: vec3<f32>, gravity_mode: i32, direction: vec3<f32>, center: vec3<f32>, magnitude: f32) -> vec3<f32> {
    // TODO: gE = normalize(direction) * magnitude, or towards center when gravity_mode == 1
    return vec3<f32>(0.0, -magnitude, 0.0);
}

// Front gravity gF = factor * |gE| * f (eq. 2).
fn front_gravity(g_env: vec3<f32>, f: vec3<f32>, factor: f32) -> vec3<f32> {
    // TODO
    return vec3<f32>(0.0);
}

// Wind force w = W * fd * fr (eq. 3-5).
fn wind_force(W: vec3<f32>, v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    // TODO: fd (directional alignment), fr (height ratio)
    return W;
}

// One step of the tip: recovery r = (iv2 - v2) * stiffness, taken at the end of the step.
fn integrate_tip(v2: vec3<f32>, iv2: vec3<f32>, stiffness: f32, accel: vec3<f32>, dt: f32) -> vec3<f32> {
    // TODO: v2' = v2 + dt * (accel + stiffness * (iv2 - v2)) / (1 + stiffness * dt)
    return v2 + dt * accel;
}
"""

_FORCES_SOLUTION = """\
// SOLUTION (teacher's answer) of the exercise "forces".

fn environmental_gravity(v0: vec3<f32>, gravity_mode: i32, direction: vec3<f32>, center: vec3<f32>, magnitude: f32) -> vec3<f32> {
    var d = direction;
    if (gravity_mode == 1) {
        d = center - v0;
    }
    return d / max(length(d), 1e-12) * magnitude;
}

fn front_gravity(g_env: vec3<f32>, f: vec3<f32>, factor: f32) -> vec3<f32> {
    return factor * length(g_env) * f;
}

fn wind_force(W: vec3<f32>, v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    let strength = length(W);
    if (strength <= 1e-12) {
        return vec3<f32>(0.0);
    }
    let fd = 1.0 - abs(dot(W / strength, normalize(v2 - v0)));
    let fr = dot(v2 - v0, up) / height;
    return W * (fd * fr);
}

fn integrate_tip(v2: vec3<f32>, iv2: vec3<f32>, stiffness: f32, accel: vec3<f32>, dt: f32) -> vec3<f32> {
    let recovery = stiffness * (iv2 - v2);
    return v2 + dt * (accel + recovery) / (1.0 + stiffness * dt);
}
"""

_VALIDATION_STARTER = """\
// Exercise "validation": fill in the three functions (keep their signatures).
// struct Guides { v1: vec3<f32>, v2: vec3<f32> } is declared by the shader.

// Keep v2 above the blade's ground plane (through v0, normal up).
fn validate_ground(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>) -> vec3<f32> {
    // TODO
    return v2;
}

// v1 from how far the tip leans (eq. 6-7).
fn validate_v1(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    // TODO: l_proj, then v1 = v0 + height * up * max(1 - l_proj / h, 0.05 * max(l_proj / h, 1))
    return v0 + up * height;
}

// Scale the curve v0, v1, v2 to length height (eq. 8-10).
fn validate_length(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, height: f32) -> Guides {
    // TODO: L = (2 L0 + L1) / 3, r = height / L
    return Guides(v1, v2);
}
"""

_VALIDATION_SOLUTION = """\
// SOLUTION (teacher's answer) of the exercise "validation".

fn validate_ground(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>) -> vec3<f32> {
    return v2 - up * min(dot(up, v2 - v0), 0.0);
}

fn validate_v1(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    let d = v2 - v0;
    let l_proj = length(d - up * dot(d, up));
    let ratio = l_proj / height;
    return v0 + up * (height * max(1.0 - ratio, 0.05 * max(ratio, 1.0)));
}

fn validate_length(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, height: f32) -> Guides {
    let l0 = length(v2 - v0);
    let l1 = length(v2 - v1) + length(v1 - v0);
    let r = height / max((2.0 * l0 + l1) / 3.0, 1e-12);
    let v1_new = v0 + r * (v1 - v0);
    return Guides(v1_new, v1_new + r * (v2 - v1));
}
"""

_CULLING_STARTER = """\
// Exercise "culling": fill in the three tests (keep their signatures). Return true to CULL the blade.

// Seen edge-on: |dot(normalize(v0 - cam_pos), t1)| > threshold.
fn orientation_cull(v0: vec3<f32>, t1: vec3<f32>, cam_pos: vec3<f32>, threshold: f32) -> bool {
    // TODO
    return false;
}

// v0, the curve midpoint and v2 all outside the view (clip space, slack tol on x and y).
fn frustum_cull(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, view_proj: mat4x4<f32>, tol: f32) -> bool {
    // TODO: m = 0.25 v0 + 0.5 v1 + 0.25 v2; p' = view_proj * vec4<f32>(p, 1.0)
    return false;
}

// Thin the field with the distance on the ground.
fn distance_cull(v0: vec3<f32>, up: vec3<f32>, cam_pos: vec3<f32>, id: u32, buckets: u32, d_max: f32) -> bool {
    // TODO: keep ceil(buckets * max(1 - d / d_max, 0)) of every buckets blades
    return false;
}
"""

_CULLING_SOLUTION = """\
// SOLUTION (teacher's answer) of the exercise "culling".

fn orientation_cull(v0: vec3<f32>, t1: vec3<f32>, cam_pos: vec3<f32>, threshold: f32) -> bool {
    return abs(dot(normalize(v0 - cam_pos), t1)) > threshold;
}

fn outside_view(p: vec3<f32>, view_proj: mat4x4<f32>, tol: f32) -> bool {
    let c = view_proj * vec4<f32>(p, 1.0);
    let lim = c.w + tol;
    return !(abs(c.x) <= lim && abs(c.y) <= lim && c.z >= 0.0 && c.z <= c.w);
}

fn frustum_cull(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, view_proj: mat4x4<f32>, tol: f32) -> bool {
    let m = 0.25 * v0 + 0.5 * v1 + 0.25 * v2;
    return outside_view(v0, view_proj, tol) && outside_view(m, view_proj, tol) && outside_view(v2, view_proj, tol);
}

fn distance_cull(v0: vec3<f32>, up: vec3<f32>, cam_pos: vec3<f32>, id: u32, buckets: u32, d_max: f32) -> bool {
    let d = v0 - cam_pos;
    let d_ground = length(d - up * dot(d, up));
    let keep = ceil(f32(buckets) * max(1.0 - d_ground / d_max, 0.0));
    return f32(id % buckets) >= keep;
}
"""

_FORCES = ExerciseSpec(
    "forces", "Forces: gravity, recovery, wind", "simulation",
    (
        ExerciseFunction("environmental_gravity", "gravity gE", "gE = normalize(D) · |g| (eq. 1), or towards a point",
                         "m/s²"),
        ExerciseFunction("front_gravity", "front gravity gF", "gF = factor · |gE| · f (eq. 2)", "m/s²"),
        ExerciseFunction("wind_force", "wind w", "w = W · fd · fr (eq. 3-5)", "m/s²"),
        ExerciseFunction("integrate_tip", "recovery and the step",
                         "r = (iv2 − v2) s; v2' = v2 + dt (accel + r) / (1 + s dt)", "m"),
    ),
    _FORCES_TASK + "\n" + _UNITS, _FORCES_STARTER, _FORCES_SOLUTION, _simulation_cases,
)

_VALIDATION = ExerciseSpec(
    "validation", "State validation: ground, v1, length", "simulation",
    (
        ExerciseFunction("validate_ground", "tip above the ground", "v2 − up · min(up · (v2 − v0), 0)", "m"),
        ExerciseFunction("validate_v1", "v1 from the lean", "v1 = v0 + h up max(1 − l/h, 0.05 max(l/h, 1)) (eq. 6-7)",
                         "m"),
        ExerciseFunction("validate_length", "curve length h", "r = h / L, L = (2 L0 + L1) / 3 (eq. 8-10)", "m"),
    ),
    _VALIDATION_TASK + "\n" + _UNITS, _VALIDATION_STARTER, _VALIDATION_SOLUTION, _simulation_cases,
)

_CULLING = ExerciseSpec(
    "culling", "Culling: orientation, frustum, distance", "culling",
    (
        ExerciseFunction("orientation_cull", "orientation test", "|normalize(v0 − c) · t1| > threshold", "-"),
        ExerciseFunction("frustum_cull", "view-frustum test", "v0, m, v2 all outside clip space (with tol)", "-"),
        ExerciseFunction("distance_cull", "distance test", "id mod n ≥ ⌈n max(1 − d/d_max, 0)⌉", "-"),
    ),
    _CULLING_TASK, _CULLING_STARTER, _CULLING_SOLUTION, _culling_cases,
)

_SPECS = {spec.name: spec for spec in (_FORCES, _VALIDATION, _CULLING)}

#: The names of the exercises, in the assignment's order.
EXERCISES = tuple(_SPECS)


def exercise_spec(name: str) -> ExerciseSpec:
    """The definition of exercise ``name`` (one of :data:`EXERCISES`)."""
    if name not in _SPECS:
        raise GrassValueError(f"name must be one of {', '.join(map(repr, EXERCISES))}; got {name!r}")
    return _SPECS[name]


# ------------------------------------------------------------------ the "derive it" variant
#
# The same functions, cases, solution and grader; the task gives the physics in words and
# points at the reference's behaviour (its values on the grading cases: reference_examples)
# instead of the equations. The starters' comments give no formula either.

_DERIVE_INTRO = (
    "\n**Derive it.** No equations here: the task says what each function must do in words. "
    "Work out the formula yourself from the words, the paper (Jahrmann & Wimmer, I3D 2017) and the reference's "
    "behaviour: `ex.examples(name)` lists what the reference function returns for inputs taken from the grading "
    "cases, and the NumPy twins (`gw.reference.<name>`) can be called on inputs of your own. "
    "The grader is the same as in the exercise with the equations.\n")

_FORCES_DERIVE_TASK = r"""
### Exercise "forces", derive it: the three forces on a blade tip (paper section 5.1)

A blade is a quadratic Bézier curve from its root v0 through v1 to the tip guide **v2**; the simulation moves
v2 (v1 follows from the state validation). Write four WGSL functions that the simulation pass calls once per blade
and step:

1. **Environmental gravity** (`environmental_gravity`): an acceleration of the given magnitude (m/s²). In
   direction mode (`gravity_mode` 0) it points along `direction`, however long that vector is; in point mode (1)
   it points from the blade's root towards `center` (a planet under the field). A root sitting exactly on the
   centre feels no pull.
2. **Front gravity** (`front_gravity`): the paper adds a pull along the blade's front direction `f` (a unit
   vector) so that blades bend forwards, not only down. Its strength is a fraction `factor` of the
   environmental gravity's strength (the paper uses a quarter).
3. **Wind** (`wind_force`): `W` is the wind field at the root. A blade that already points along the wind
   (its root-to-tip direction parallel or anti-parallel to W) offers no face to it and feels no force; one
   across the wind feels all of it. A blade lying flat on its ground plane is out of the wind; an upright
   one feels all of it, in proportion to how high its tip stands above the ground plane, measured in blade
   heights. No wind, no force.
4. **Recovery and the step** (`integrate_tip`): a spring of stiffness `stiffness` (1/s²) pulls the tip back
   towards its rest position `iv2` (straight up, one height above the root), proportional to the distance.
   Advance the tip by one step of `dt` under that spring and the acceleration `accel` (gravity and wind).
   The plain explicit step overshoots and oscillates for stiff blades (`stiffness * dt` > 1); the reference
   treats the spring implicitly (at the end of the step) and stays stable. Find which by its values.
"""

_VALIDATION_DERIVE_TASK = r"""
### Exercise "validation", derive it: keep every blade a valid blade (paper section 5.2)

After the forces move the tip v2, three corrections keep the blade in shape, in this order:

1. **Above the ground** (`validate_ground`): a tip below the blade's own ground plane (through v0, normal `up`)
   is put back onto that plane, moving only along `up`; a tip above it is left alone.
2. **v1 from the lean** (`validate_v1`): the middle control point stands on the blade's axis, straight above
   the root. The further the tip leans away from the axis (its distance from the axis, compared with the
   blade's height), the lower v1 sits: upright blades have v1 at full height, leaning ones lower. It never goes
   all the way down: a small floor (a twentieth of the height, growing once the lean exceeds the height) keeps
   the curve from folding.
3. **Length** (`validate_length`, returning `Guides(v1, v2)`): forces stretch or shrink the curve; scale it
   about the root so its length is the blade's height again. The curve's length is estimated from the chord
   (root to tip) and the control polygon (root to v1 to tip), as the paper does for a degree-2 curve; the stock
   helper `curve_length(v0, v1, v2)` gives that estimate. Both guides move by the same factor.
"""

_CULLING_DERIVE_TASK = r"""
### Exercise "culling", derive it: three tests that skip blades before drawing (paper section 6)

The culling pass runs every frame, one thread per blade; each function returns `true` to **cull** (skip):

1. **Orientation** (`orientation_cull`): a blade is flat; seen edge-on it covers almost no pixels. Compare the
   direction from the camera to the root with the blade's width direction `t1` (unit): cull when they are
   nearly parallel, more so than `threshold` allows (seen from either side).
2. **View frustum** (`frustum_cull`): a blade is kept when any of three points, the root, a point in the
   middle of the curve and the tip guide, is inside the view. Inside means inside the clip volume WebGPU
   uses (`view_proj` maps world to clip space), with a slack of `tol` on the sides only, never in depth.
3. **Distance** (`distance_cull`): thin the field far away. Measure the distance from the camera to the root
   along the ground (ignore height above the ground plane). Blades are grouped in `buckets` classes by their
   `id`; near the camera all classes are drawn, fewer with the distance, none from `d_max` on, and a class
   is drawn at a distance only if every lower class is.
"""

_DERIVE_STARTERS = {
    "forces": """\
// Exercise "forces", derive it: fill in the four functions (keep their signatures).
// Vectors in metres, accelerations in m/s^2, stiffness in 1/s^2, dt in s.

// Gravity of the environment. gravity_mode 0: along direction; 1: towards center.
fn environmental_gravity(v0: vec3<f32>, gravity_mode: i32, direction: vec3<f32>, center: vec3<f32>, magnitude: f32) -> vec3<f32> {
    // TODO
    return vec3<f32>(0.0, -magnitude, 0.0);
}

// The pull along the blade's front direction f.
fn front_gravity(g_env: vec3<f32>, f: vec3<f32>, factor: f32) -> vec3<f32> {
    // TODO
    return vec3<f32>(0.0);
}

// The wind's force on the blade, W the wind at the root.
fn wind_force(W: vec3<f32>, v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    // TODO
    return W;
}

// One step of the tip under the spring back to iv2 and the acceleration accel.
fn integrate_tip(v2: vec3<f32>, iv2: vec3<f32>, stiffness: f32, accel: vec3<f32>, dt: f32) -> vec3<f32> {
    // TODO
    return v2 + dt * accel;
}
""",
    "validation": """\
// Exercise "validation", derive it: fill in the three functions (keep their signatures).
// struct Guides { v1: vec3<f32>, v2: vec3<f32> } is declared by the shader.

// Keep v2 on or above the blade's ground plane (through v0, normal up).
fn validate_ground(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>) -> vec3<f32> {
    // TODO
    return v2;
}

// v1 on the blade's axis, lower the more the tip leans.
fn validate_v1(v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    // TODO
    return v0 + up * height;
}

// Scale the curve about the root to the blade's height.
fn validate_length(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, height: f32) -> Guides {
    // TODO
    return Guides(v1, v2);
}
""",
    "culling": """\
// Exercise "culling", derive it: fill in the three tests (keep their signatures). Return true to CULL the blade.

// Seen edge-on.
fn orientation_cull(v0: vec3<f32>, t1: vec3<f32>, cam_pos: vec3<f32>, threshold: f32) -> bool {
    // TODO
    return false;
}

// Root, middle of the curve and tip guide all outside the view.
fn frustum_cull(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, view_proj: mat4x4<f32>, tol: f32) -> bool {
    // TODO
    return false;
}

// Thin the field with the distance along the ground.
fn distance_cull(v0: vec3<f32>, up: vec3<f32>, cam_pos: vec3<f32>, id: u32, buckets: u32, d_max: f32) -> bool {
    // TODO
    return false;
}
""",
}

#: What each function does, in words (the derive variant's "computes" column: no equation).
_DERIVE_WORDS = {
    "environmental_gravity": "along `direction`, or towards `center` in point mode; strength `magnitude`",
    "front_gravity": "along the front `f`, a fraction `factor` of gE's strength",
    "wind_force": "none along the blade or lying flat, all of it across an upright blade",
    "integrate_tip": "one stable step under a spring back to `iv2` and `accel`",
    "validate_ground": "tip back onto the ground plane, along `up` only",
    "validate_v1": "v1 on the axis, lower the more the tip leans, never below a floor",
    "validate_length": "curve scaled about the root to length `height`",
    "orientation_cull": "true when seen nearly edge-on",
    "frustum_cull": "true when root, middle and tip are all outside clip space",
    "distance_cull": "true for the classes beyond what the ground distance keeps",
}

_DERIVE_TASKS = {"forces": _FORCES_DERIVE_TASK, "validation": _VALIDATION_DERIVE_TASK,
                 "culling": _CULLING_DERIVE_TASK}


def _derive_spec(spec: ExerciseSpec) -> ExerciseSpec:
    functions = tuple(ExerciseFunction(f.name, f.label, _DERIVE_WORDS[f.name], f.units) for f in spec.functions)
    task = _DERIVE_TASKS[spec.name] + _DERIVE_INTRO + ("\n" + _UNITS if spec.kind == "simulation" else "")
    return ExerciseSpec(spec.name, spec.title + " (derive it)", spec.kind, functions, task,
                        _DERIVE_STARTERS[spec.name], spec.solution, spec.make_cases, variant="derive")


_DERIVED = {name: _derive_spec(spec) for name, spec in _SPECS.items()}

#: The variants of every exercise: "equations" (the task gives the paper's equations; the default)
#: and "derive" (the physics in words and the reference's behaviour; the formulas are the student's).
VARIANTS = ("equations", "derive")


def exercise_variant(name: str, variant: str = "equations") -> ExerciseSpec:
    """The definition of exercise ``name`` (one of :data:`EXERCISES`) in ``variant`` (one of
    :data:`VARIANTS`; default "equations")."""
    spec = exercise_spec(name)
    if not isinstance(variant, str) or variant not in VARIANTS:
        raise GrassValueError(f"variant must be one of {', '.join(map(repr, VARIANTS))}; got {variant!r}")
    return _DERIVED[spec.name] if variant == "derive" else spec


def _example_camera(case):
    from .camera_rules import view_proj

    aspect = case.size[0] / case.size[1]
    return view_proj(case.position, case.target, case.fov_deg, 0.1, 1000.0, aspect), np.asarray(case.position, float)


def reference_examples(spec: ExerciseSpec, name: str, count: int = 6) -> list:
    """What the reference function ``name`` returns for inputs of the grading cases: a list of
    ``count`` (1 to 64, default 6) dicts ``case``, ``blade``, ``inputs`` (the function's
    arguments by name) and ``reference`` (its NumPy twin's value), spread over the cases and
    blades (the same every call). Culling cameras use a near plane of 0.1 m and a far plane
    of 1000 m."""
    from .params import GrassParams

    spec.function(name)  # a clear error for a name not in this exercise
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or not 1 <= count <= 64:
        raise GrassValueError(f"count must be a whole number from 1 to 64; got {count!r}")
    cases = spec.cases()
    rng = np.random.default_rng(7)
    rows = []
    for i in range(int(count)):
        case = cases[i % len(cases)]
        params = GrassParams(**case.params)
        k = int(rng.integers(len(case.state["v0"])))
        if spec.kind == "simulation":
            trace = step_trace(case.state, params, case.step_index * params.dt, case.spheres)
            inputs, value = function_io(name, trace, params, k)
        else:
            vp, cam_pos = _example_camera(case)
            inputs, value = cull_io(name, case.state, params, vp, cam_pos, k)
        rows.append(dict(case=case.name, blade=k, inputs=inputs, reference=value))
    return rows
