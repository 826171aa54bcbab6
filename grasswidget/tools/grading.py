"""The exercise grader: a student's WGSL in the real passes, against the NumPy reference.

:func:`grade` takes an exercise (:mod:`grasswidget.core.exercises`) and the student's
WGSL and returns a :class:`~grasswidget.core.grade_report.GradeReport`:

1. Checks before compiling (:meth:`FunctionOverrides.check`): every function there with
   its stock signature, no loops. Then one compile of all the student's functions into
   the simulation shader (which holds all the blade math). Either failure raises
   :class:`~grasswidget.errors.ExerciseShaderError` naming the student's line and column.
2. Per function, the student's version alone replaces the stock one
   (:meth:`FunctionOverrides.only`; the others stay stock, so an error belongs to that
   function), in the kernel engine's real passes, headless:

   - simulation exercises: ``GrassField.step(1)`` from each case's state (its params,
     time and spheres), compared blade by blade (v1 and v2) with
     :func:`grasswidget.core.reference.simulate`; error in blade heights, tolerance
     :data:`~grasswidget.core.exercises.SIM_TOLERANCE`; a NaN or infinity fails as "NaN";
   - the culling exercise: a render of each case's camera with only that test switched
     on (occlusion and the compute rasterizer off), the drawn blades
     (``GrassField.read_visible``) compared with :func:`grasswidget.core.reference.cull_reason`;
     blades within 1e-4 of the test's threshold are left out (float32 may decide either way).

Isolation: the checks before compiling (step 1's rules and the size limits of
:mod:`grasswidget.core.wgsl_limits`: length, nesting, statement length, array sizes,
inlined size) run in the kernel and name the student's line. Everything that compiles or
runs the student's code (steps 1 and 2: :func:`grade_here`) runs in the isolated worker
process of :mod:`grasswidget.gpu.isolation` (its own GPU device, a time and a memory
limit, reused from grade to grade): a compiler crash, a compile that does not end, a
runaway allocation or a lost device becomes an ExerciseShaderError naming the cause (and,
but for the time limit, the function at fault: :func:`locate_failure`), and the kernel,
its device and the next grade are untouched.
"""

from __future__ import annotations

import numpy as np

from ..core import reference as ref
from ..core.blades import Blades
from ..core.colliders import SphereCollider
from ..core.exercises import SIM_TOLERANCE, cull_io, function_io, near_cull_threshold, step_trace
from ..core.grade_report import FunctionGrade, GradeReport
from ..core.params import GrassParams
from ..core.shader_files import render_wgsl
from ..core.wgsl_overrides import FunctionOverrides, parse_functions
from ..errors import ExerciseShaderError, GrassTypeError, IsolatedRunError

__all__ = ["grade", "grade_here", "overrides_for", "check_compiles", "locate_failure"]


def overrides_for(spec, wgsl: str) -> FunctionOverrides:
    """The student's ``wgsl`` as checked overrides of exercise ``spec``'s functions
    (ExerciseShaderError before compiling: missing function, wrong signature, loop)."""
    if not isinstance(wgsl, str):
        raise GrassTypeError(f"wgsl must be a str (the WGSL of your functions); got {type(wgsl).__name__}")
    return FunctionOverrides(wgsl, spec.names, label=f"your {spec.name} code").check(render_wgsl("blade_math.wgsl"))


def check_compiles(overrides: FunctionOverrides):
    """Compile ``overrides`` into the simulation shader with the kernel's adapter (which
    holds every blade-math function): ExerciseShaderError with the student's line and
    column when it does not compile. Skipped (returns False) when the kernel has no GPU
    adapter; True when it compiled."""
    from ..errors import NoGPUAdapterError
    from ..gpu.field import GrassField

    try:
        field = GrassField(Blades.on_plane(1))
    except NoGPUAdapterError:
        return False
    try:
        field.set_function_overrides(overrides)
    finally:
        field.release()
    return True


def _adapter_name() -> str:
    from ..gpu.adapter import adapter_info

    info = adapter_info()
    return str(info.get("device") or info.get("summary") or "GPU")


def grade(spec, wgsl: str, *, worker=None) -> GradeReport:
    """Grade ``wgsl`` (the student's functions) for exercise ``spec`` (an ExerciseSpec);
    see the module docstring. Never raises for wrong results (the report says what is
    wrong); raises ExerciseShaderError for code that does not compile or breaks a rule,
    and for code that crashed, hung or exhausted the isolated worker (``reason`` names
    the cause, e.g. "crashed the shader compiler (segmentation fault)"). ``worker``: the
    :class:`~grasswidget.gpu.isolation.IsolatedWorker` to grade in (default the shared one).
    """
    from ..gpu.isolation import in_worker, shared_worker, verdict_message

    overrides_for(spec, wgsl)  # the rules and limits, in the kernel: the student's line
    if in_worker():
        return grade_here(spec, wgsl)
    label = f"your {spec.name} code"
    worker = worker or shared_worker()
    try:
        return worker.call(grade_here, spec, wgsl, what=f"grading {label}")
    except IsolatedRunError as err:
        if err.cause == "start":  # the worker, not the student's code
            raise
        where = None
        if err.cause != "time":  # a crash, memory or a lost device comes back in seconds: find the function
            where = locate_failure(FunctionOverrides(wgsl, spec.names, label=label), worker)
        if where is None:
            raise ExerciseShaderError(verdict_message(err, label), None, None, err.verdict, err.detail) from None
        name, line, column = where
        message = verdict_message(err, f"{label} line {line} (`{name}`)")
        row = wgsl.split("\n")[line - 1]
        raise ExerciseShaderError(f"{message}\n  {line} | {row[:160]}", line, column, err.verdict,
                                  err.detail) from None


def locate_failure(overrides, worker=None):
    """Which of ``overrides``' functions takes the compiler or the driver down: each is
    compiled alone (the stock blade math, the student's helpers, that function, and an entry
    point that calls it) in ``worker`` (default the shared
    :class:`~grasswidget.gpu.isolation.IsolatedWorker`). Returns (name, line, column) of
    the function's definition in the student's code when exactly some of them fail, None
    when none does or all do (then the cause is in code they share, or elsewhere).
    Each failure costs a worker start on the next call."""
    from ..gpu.isolation import PROBE_ENTRY, probe_entry, shared_worker

    worker = worker or shared_worker()
    stock_code = render_wgsl("blade_math.wgsl")
    stock = {f.name: f for f in parse_functions(stock_code)}
    mine = {f.name: f for f in parse_functions(overrides.code)}
    failed = []
    for name in overrides.names:
        text = overrides.only(name).apply(stock_code)
        text += probe_entry([(name, [t for _, t in stock[name].params], stock[name].returns)], text)
        try:
            worker.check_compute(text, PROBE_ENTRY, timeout_s=min(worker.timeout_s, 20.0))
        except IsolatedRunError:
            failed.append(name)
    if not failed or len(failed) == len(overrides.names) or failed[0] not in mine:
        return None
    f = mine[failed[0]]
    return f.name, f.line, f.column


def grade_here(spec, wgsl: str) -> GradeReport:
    """Grade ``wgsl`` for ``spec`` in this process (what :func:`grade` runs in the
    isolated worker); the same result and errors, with nothing between the student's code
    and this process's device."""
    overrides = overrides_for(spec, wgsl)
    cases = spec.cases()
    if spec.kind == "simulation":
        grades = _grade_simulation(spec, overrides, cases)
    else:
        grades = _grade_culling(spec, overrides, cases)
    return GradeReport(spec.name, spec.title, grades, _adapter_name(), tuple(c.name for c in cases))


# ------------------------------------------------------------------ simulation


def _blades_of(state) -> Blades:
    return Blades(v0=state["v0"], up=state["up"], orientation=state["orientation"], height=state["height"],
                  width=state["width"], stiffness=state["stiffness"])


def _sim_field(case):
    from ..gpu.field import GrassField

    params = GrassParams(**case.params)
    field = GrassField(_blades_of(case.state), params=params)
    field.simulation.max_grid_cells = 1  # every blade tests every sphere: the grid stays valid for any state
    field.colliders = [SphereCollider(center=tuple(float(x) for x in s[:3]), radius=float(s[3])) for s in case.spheres]
    return field


def _probe(overrides, name, cases_inputs):
    """The student's ``name`` called alone on the GPU with each blade's inputs
    (:mod:`grasswidget.gpu.function_probe`): {leaf: array over all blades of all cases}."""
    from ..gpu.function_probe import call_function

    stock = render_wgsl("blade_math.wgsl")
    (fn,) = [f for f in parse_functions(stock) if f.name == name]
    rows = [inputs for case_inputs in cases_inputs for inputs in case_inputs]
    columns = [np.array([np.asarray(row[p], np.float64) if not isinstance(row[p], (int, np.integer)) else row[p]
                         for row in rows]) for p, _ in fn.params]
    return call_function(overrides.only(name).apply(stock), name, [t for _, t in fn.params], fn.returns, columns)


def _leaf_value(leaves, k):
    if list(leaves) == ["r"]:
        return leaves["r"][k]
    return {key.split(".", 1)[1]: v[k] for key, v in leaves.items()}


def _grade_simulation(spec, overrides, cases) -> list:
    fields = [_sim_field(case) for case in cases]
    try:
        fields[0].set_function_overrides(overrides)  # all of the student's code at once: compile errors
        expected, traces = [], []
        for case, field in zip(cases, fields):
            t = case.step_index * field.params.dt
            expected.append(ref.simulate(case.state, field.params, 1, first_step=case.step_index,
                                         colliders=case.spheres))
            traces.append(step_trace(case.state, field.params, t, case.spheres))
        grades = []
        for fn in spec.functions:
            one = overrides.only(fn.name)
            io = [[function_io(fn.name, trace, field.params, k) for k in range(len(case.state["v0"]))]
                  for case, field, trace in zip(cases, fields, traces)]
            probed = _probe(overrides, fn.name, [[inputs for inputs, _ in rows] for rows in io])
            finite_value = np.all([np.isfinite(v).reshape(len(v), -1).all(axis=1) for v in probed.values()], axis=0)
            worst, wrong, checked, first, offset = 0.0, 0, 0, None, 0
            for c, (case, field, exp) in enumerate(zip(cases, fields, expected)):
                field.set_function_overrides(one)
                field.write_state(case.state)
                field.step_count = case.step_index
                field.step(1)
                got = field.read_state()
                n = len(case.state["v0"])
                h = np.asarray(case.state["height"], np.float64)
                err = np.maximum(np.linalg.norm(got["v1"] - exp["v1"], axis=1),
                                 np.linalg.norm(got["v2"] - exp["v2"], axis=1)) / h
                finite = (np.isfinite(got["v1"]).all(axis=1) & np.isfinite(got["v2"]).all(axis=1)
                          & finite_value[offset: offset + n])
                err = np.where(finite, err, np.inf)
                bad = err > SIM_TOLERANCE
                checked += n
                wrong += int(bad.sum())
                worst = max(worst, float(err.max()))
                if bad.any() and first is None:
                    k = int(np.argmax(~finite)) if not finite.all() else int(np.argmax(bad))
                    inputs, reference = io[c][k]
                    first = dict(case=case.name, case_description=case.description, blade=k, inputs=inputs,
                                 reference=reference, your_value=_leaf_value(probed, offset + k),
                                 expected={"v1": exp["v1"][k], "v2": exp["v2"][k]},
                                 yours={"v1": got["v1"][k].astype(np.float64), "v2": got["v2"][k].astype(np.float64)})
                offset += n
            verdict = "NaN" if not finite_value.all() else ("fail" if wrong else "pass")
            grades.append(FunctionGrade(fn.name, fn.label, verdict, worst, "blade heights", checked, wrong,
                                        SIM_TOLERANCE, first))
        return grades
    finally:
        for field in fields:
            field.release()


# ------------------------------------------------------------------ culling

_TESTS = {"orientation_cull": "cull_orientation", "frustum_cull": "cull_frustum", "distance_cull": "cull_distance"}


def _grade_culling(spec, overrides, cases) -> list:
    from ..gpu.scene import GrassScene

    first_case = cases[0]
    params = GrassParams(cull_occlusion=False, compute_raster=False, lod=False)
    scene = GrassScene(_blades_of(first_case.state), size=first_case.size, params=params)
    try:
        scene.field.set_function_overrides(overrides)
        grades = []
        for fn in spec.functions:
            scene.field.set_function_overrides(overrides.only(fn.name))
            wrong, checked, first = 0, 0, None
            for case in cases:
                for name, value in case.params.items():
                    setattr(params, name, value)
                for test_name, trait in _TESTS.items():
                    setattr(params, trait, test_name == fn.name)
                scene.field.write_state(case.state)
                scene.look(case.position, case.target, case.fov_deg)
                scene.render()
                cam = scene.camera
                view_proj = np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64)
                cam_pos = np.asarray(cam.world.position, np.float64)
                culled_expected = ref.cull_reason(case.state, params, view_proj, cam_pos) != 0
                culled = np.ones(len(culled_expected), bool)
                culled[scene.field.read_visible()] = False
                skip = near_cull_threshold(fn.name, case.state, params, view_proj, cam_pos)
                bad = (culled != culled_expected) & ~skip
                checked += int((~skip).sum())
                wrong += int(bad.sum())
                if bad.any() and first is None:
                    k = int(np.argmax(bad))
                    inputs, reference = cull_io(fn.name, case.state, params, view_proj, cam_pos, k)
                    first = dict(case=case.name, case_description=case.description, blade=k, inputs=inputs,
                                 reference=reference, expected=bool(culled_expected[k]), yours=bool(culled[k]))
            grades.append(FunctionGrade(fn.name, fn.label, "fail" if wrong else "pass", float(wrong), "blades",
                                        checked, wrong, 0.0, first))
        return grades
    finally:
        scene.release()
