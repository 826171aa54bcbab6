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
from ..core.exercises import (SIM_TOLERANCE, cull_details, cull_io, cull_margin, function_calls, near_cull_threshold,
                               step_trace)
from ..core.grade_report import FunctionGrade, GradeReport
from ..core.params import GrassParams
from ..core.shader_files import render_wgsl
from ..core.student_wgsl import TRAP_VAR, check_names, instrument
from ..core.wgsl_overrides import FunctionOverrides, parse_functions
from ..errors import ExerciseShaderError, GrassTypeError, IsolatedRunError

__all__ = ["grade", "grade_here", "overrides_for", "check_compiles", "locate_failure"]


def overrides_for(spec, wgsl: str) -> FunctionOverrides:
    """The student's ``wgsl`` as checked overrides of exercise ``spec``'s functions
    (ExerciseShaderError before compiling: a NUL or another control character, the
    engine's bindings such as ``u_sim`` or ``s_blades``, entry points, missing function,
    wrong signature, loop; :func:`grasswidget.core.student_wgsl.check_names` and
    :meth:`FunctionOverrides.check`)."""
    if not isinstance(wgsl, str):
        raise GrassTypeError(f"wgsl must be a str (the WGSL of your functions); got {type(wgsl).__name__}")
    label = f"your {spec.name} code"
    check_names(wgsl, label)
    return FunctionOverrides(wgsl, spec.names, label=label).check(render_wgsl("blade_math.wgsl"))


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


def _probe(overrides, name, rows):
    """The student's ``name`` called alone on the GPU with each row of inputs (a dict of
    its arguments; :mod:`grasswidget.gpu.function_probe`), its divisions and the like
    trapped (:func:`grasswidget.core.student_wgsl.instrument`). Returns ({leaf: array over
    the rows}, trap (int per row: the 1-based trap site that fired first, 0 none), sites)."""
    from ..gpu.function_probe import call_function

    stock = render_wgsl("blade_math.wgsl")
    (fn,) = [f for f in parse_functions(stock) if f.name == name]
    columns = [np.array([np.asarray(row[p], np.float64) if not isinstance(row[p], (int, np.integer)) else row[p]
                         for row in rows]) for p, _ in fn.params]
    types = [t for _, t in fn.params]
    one = overrides.only(name)
    code, sites = instrument(one.code)
    if sites:
        try:
            module = FunctionOverrides(code, (name,), one.label).apply(stock)
            out = call_function(module, name, types, fn.returns, columns, read_after=(TRAP_VAR,))
            return out, out.pop(TRAP_VAR).astype(int), sites
        except Exception:  # noqa: BLE001 - the traps could not be compiled (e.g. an abstract constant): probe without
            pass
    out = call_function(one.apply(stock), name, types, fn.returns, columns)
    return out, np.zeros(len(rows), int), []


def _leaf_value(leaves, k):
    if list(leaves) == ["r"]:
        return leaves["r"][k]
    return {key.split(".", 1)[1]: v[k] for key, v in leaves.items()}


def _flat(value):
    if isinstance(value, dict):
        return np.concatenate([np.ravel(np.asarray(v, np.float64)) for v in value.values()])
    return np.ravel(np.asarray(value, np.float64))


def _difference(a, b) -> float:
    """The largest difference of two function values (inf where one is not finite)."""
    a, b = _flat(a), _flat(b)
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        return np.inf
    return float(np.max(np.abs(a - b))) if a.size else 0.0


def _trap_text(sites, site):
    return sites[site - 1].describe() if site and site <= len(sites) else None


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
        return [_grade_simulated_function(fn, overrides, cases, fields, expected, traces) for fn in spec.functions]
    finally:
        for field in fields:
            field.release()


def _grade_simulated_function(fn, overrides, cases, fields, expected, traces) -> FunctionGrade:
    """One function of a simulation exercise: every call it gets in each case probed alone,
    then one step of the real pass per case; the worst blade over all cases reported."""
    calls = [[function_calls(fn.name, trace, field.params, k) for k in range(len(case.state["v0"]))]
             for case, field, trace in zip(cases, fields, traces)]
    rows, where = [], []  # where[c][k] = (first row, number of calls) of blade k of case c
    for blade_calls in calls:
        where.append([])
        for one_blade in blade_calls:
            where[-1].append((len(rows), len(one_blade)))
            rows += [inputs for _, inputs, _ in one_blade]
    probed, trap, sites = _probe(overrides, fn.name, rows)
    finite_row = np.all([np.isfinite(v).reshape(len(v), -1).all(axis=1) for v in probed.values()], axis=0)
    one = overrides.only(fn.name)
    wrong, checked, worst, nonfinite_any, failed_cases = 0, 0, 0.0, not finite_row.all(), []
    best = None  # (key, case index, blade, errors, got)
    for c, (case, field, exp) in enumerate(zip(cases, fields, expected)):
        field.set_function_overrides(one)
        field.write_state(case.state)
        field.step_count = case.step_index
        field.step(1)
        got = field.read_state()
        n = len(case.state["v0"])
        h = np.asarray(case.state["height"], np.float64)
        e1 = np.linalg.norm(got["v1"] - exp["v1"], axis=1) / h
        e2 = np.linalg.norm(got["v2"] - exp["v2"], axis=1) / h
        first = np.array([r for r, _ in where[c]])
        count = np.array([m for _, m in where[c]])
        probe_finite = np.array([finite_row[r: r + m].all() for r, m in zip(first, count)])
        trapped = np.array([int(next((t for t in trap[r: r + m] if t), 0)) for r, m in zip(first, count)])
        finite = np.isfinite(got["v1"]).all(axis=1) & np.isfinite(got["v2"]).all(axis=1) & probe_finite
        err = np.where(finite, np.maximum(e1, e2), np.inf)
        bad = err > SIM_TOLERANCE
        nonfinite_any |= bool((bad & (trapped > 0)).any())
        checked += n
        wrong += int(bad.sum())
        worst = max(worst, float(err.max()))
        if bad.any():
            failed_cases.append(case.name)
        for k in np.flatnonzero(bad):
            key = (not finite[k] or trapped[k] > 0, float(err[k]))
            if best is None or key > best[0]:
                best = (key, c, int(k), (float(e1[k]), float(e2[k])), got, int(trapped[k]))
    failure = None
    if best is not None:
        _, c, k, (e1k, e2k), got, site = best
        r0, m = where[c][k]
        diffs = [_difference(_leaf_value(probed, r0 + j), calls[c][k][j][2]) for j in range(m)]
        j = int(np.argmax(diffs))
        label, inputs, reference = calls[c][k][j]
        exp = expected[c]
        failure = dict(case=cases[c].name, case_description=cases[c].description, blade=k, call=label,
                       call_index=j, calls=m, inputs=inputs, reference=reference,
                       your_value=_leaf_value(probed, r0 + j), errors={"v1": e1k, "v2": e2k},
                       trap=_trap_text(sites, site or int(next((t for t in trap[r0: r0 + m] if t), 0))),
                       expected={"v1": exp["v1"][k], "v2": exp["v2"][k]},
                       yours={"v1": got["v1"][k].astype(np.float64), "v2": got["v2"][k].astype(np.float64)})
    verdict = "NaN" if nonfinite_any else ("fail" if wrong else "pass")
    return FunctionGrade(fn.name, fn.label, verdict, worst, "blade heights", checked, wrong, SIM_TOLERANCE, failure,
                         tuple(failed_cases))


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
            wrong, checked, best, failed_cases = 0, 0, None, []
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
                if bad.any():  # the wrongly decided blade the reference decides most clearly
                    failed_cases.append(case.name)
                    margin = np.where(bad, cull_margin(fn.name, case.state, params, view_proj, cam_pos), -1.0)
                    k = int(np.argmax(margin))
                    if best is None or margin[k] > best[0]:
                        inputs, reference = cull_io(fn.name, case.state, params, view_proj, cam_pos, k)
                        exact = dict(inputs, view_proj=view_proj) if "view_proj" in inputs else inputs
                        best = (float(margin[k]), dict(
                            case=case.name, case_description=case.description, blade=k, inputs=inputs,
                            reference=reference, probe_inputs=exact, expected=bool(culled_expected[k]),
                            yours=bool(culled[k]), details=cull_details(fn.name, case.state, params, view_proj,
                                                                        cam_pos, k)))
            failure = None
            if best is not None:
                failure = best[1]
                probed, trap, sites = _probe(overrides, fn.name, [failure.pop("probe_inputs")])
                failure["your_value"] = bool(probed["r"][0])
                failure["trap"] = _trap_text(sites, int(trap[0]))
            verdict = ("NaN" if failure["trap"] else "fail") if failure else "pass"
            grades.append(FunctionGrade(fn.name, fn.label, verdict, float(wrong), "blades", checked, wrong, 0.0,
                                        failure, tuple(failed_cases)))
        return grades
    finally:
        scene.release()
