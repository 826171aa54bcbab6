"""User code that takes a compiler or a driver down cannot reach the kernel (issue 38).

The submissions that took a grading kernel down are refused by their text first
(tests/core/test_wgsl_limits.py). Here they go past those checks, straight to the isolated
worker (:mod:`grasswidget.gpu.isolation`), as code that slipped through would: each gets a
verdict naming its cause (a crashed compiler, the memory limit, a lost device, the time
limit), the teacher's solution graded right after in the same worker passes, and this
process's own scenes still render. Then the same holds for ``wind_wgsl`` and function
overrides compiled for drawing, with the text checks loosened in this process only.
"""

import numpy as np
import pytest

import grasswidget as gw
from conftest import grass_mask
from grasswidget.core import wgsl_limits
from grasswidget.core.exercises import exercise_spec
from grasswidget.core.wgsl_overrides import FunctionOverrides
from grasswidget.gpu.compute import ComputeProgram
from grasswidget.gpu.adapter import is_cpu_adapter
from grasswidget.gpu.field import GrassField
from grasswidget.gpu.isolation import IsolatedWorker, compile_compute, shared_worker
from grasswidget.gpu.simulation import SimulateShader
from grasswidget.tools.grading import grade, locate_failure

FORCES = exercise_spec("forces")
LAST = "return W * (fd * fr);"


def _forces_with(old, new):
    code = FORCES.solution.replace(old, new)
    assert code != FORCES.solution
    return code


def _chain(n):
    """Helpers that each call the one before twice: 2**n calls once a driver inlines them."""
    helpers = "\n".join(["fn h0(x: f32) -> f32 { return sin(x) * 1.5; }"] + [
        f"fn h{k}(x: f32) -> f32 {{ return h{k - 1}(x) + h{k - 1}(x * 0.5); }}" for k in range(1, n + 1)])
    return _forces_with(LAST, f"return W * (fd * fr) * h{n}(fd);") + "\n" + helpers + "\n"


NESTED = "(" * 3500 + "1.0" + ")" * 3500
CASES = {
    # name: (the student's code, the worker's verdict's cause, words of the verdict)
    "nested 3500 deep": (_forces_with(LAST, f"return W * (fd * fr) * {NESTED};"), "crash",
                         "crashed the shader compiler (segmentation fault)"),
    "a sum of 50,000 terms": (_forces_with(LAST, "return W * (fd * fr) * (" + " + ".join(["1.0"] * 50_000) + ");"),
                              "crash", "crashed the shader compiler"),
    "16M private vectors": (_forces_with(LAST, "var big: array<vec4<f32>, 16777216>;\n    big[0] = vec4<f32>(W, 0.0);"
                                               "\n    return big[0].xyz * (fd * fr);"), "memory",
                            "exceeded the 256 MB memory limit"),
    "a 100,000-element const array": (
        _forces_with(LAST, "return W * (fd * fr) * BIG[u32(fd) % 100000u];").replace(
            "fn wind_force", "const BIG = array<f32, 100000>(" + ", ".join(["1.0"] * 100_000) + ");\nfn wind_force"),
        "device lost", "lost the GPU device"),
    "helpers inlined 2**20 times": (_chain(20), "time", "exceeded the 3 s time limit"),
}


@pytest.fixture(scope="module")
def worker():
    w = IsolatedWorker(timeout_s=60, memory_mb=256)
    yield w
    w.close()


@pytest.fixture(scope="module")
def stock_simulation():
    """The kernel's simulation shader, stock (the text the student's functions go into)."""
    field = GrassField(gw.Blades.on_plane(16))
    try:
        return ComputeProgram(SimulateShader(field), field).wgsl
    finally:
        field.release()


def _renders():
    scene = gw.GrassScene(gw.Blades.on_plane(256, size=2.0, seed=3), size=(64, 48))
    try:
        return int(grass_mask(scene.render()).sum())
    finally:
        scene.release()


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CASES))
def test_a_kernel_killing_compile_gets_a_verdict_and_the_next_grade_passes(name, worker, stock_simulation):
    code, cause, words = CASES[name]
    shader = FunctionOverrides(code, FORCES.names).apply(stock_simulation)  # past the text checks
    # the compile that never ends also grows (about 100 MB/s): room enough that time runs out first
    w = IsolatedWorker(timeout_s=3, memory_mb=2048) if cause == "time" else worker
    try:
        if cause == "memory" and not is_cpu_adapter():
            # A GPU driver keeps a private array in its own (local) memory: on an H200 the compile
            # of 16M private vectors takes little host memory and succeeds. Nothing to stop, then;
            # the worker must still come back from it and the next grade pass.
            try:
                w.check_compute(shader)
            except gw.IsolatedRunError as err:
                assert err.cause == cause and words in str(err), str(err)
            w.close()  # as after a verdict: the next call starts a fresh worker
        else:
            with pytest.raises(gw.IsolatedRunError) as info:
                w.check_compute(shader)
            err = info.value
            assert err.cause == cause and words in str(err) and words in err.verdict, str(err)
        assert not w.alive  # killed or gone: the next call starts a fresh one
        started = w.starts
        w.set_limits(timeout_s=60)
        report = grade(FORCES, FORCES.solution, worker=w)
        assert report.passed, str(report)
        assert w.starts == started + 1 and w.alive
    finally:
        if w is not worker:
            w.close()
    assert _renders() > 100  # this process's device is untouched


@pytest.mark.slow
def test_a_grade_past_the_time_limit_is_an_exercise_error_and_the_worker_comes_back(worker):
    worker.set_limits(timeout_s=0.05)
    try:
        with pytest.raises(gw.ExerciseShaderError) as info:
            grade(FORCES, FORCES.solution, worker=worker)
        err = info.value
        assert err.reason == "exceeded the 0.05 s time limit" and "isolated worker process" in str(err), str(err)
        assert err.line is None and not worker.alive
    finally:
        worker.set_limits(timeout_s=60)
    started = worker.starts
    assert grade(FORCES, FORCES.solution, worker=worker).passed and worker.starts == started + 1


def test_a_compile_error_in_the_worker_comes_back_as_the_compilers_message(stock_simulation):
    code = _forces_with("let fr = dot(v2 - v0, up) / height;", "let fr = dot(v2 - v0, up) / heigth;")
    message = shared_worker().check_compute(FunctionOverrides(code, FORCES.names).apply(stock_simulation))
    assert "heigth" in message
    assert compile_compute(stock_simulation) is None  # the stock shader compiles in this process too


#: Worker code (run with the builtin exec, which pickles by name) that grows by 180 MB, past half of a 256 MB limit and
#: under it, waits for the worker's watch to see it, then dies by a signal.
GROW_THEN_DIE = ("import os, signal, time\nheld = b'\\x01' * (180 << 20)\ntime.sleep(0.2)\n"
                 "os.kill(os.getpid(), signal.{signal})")


@pytest.mark.parametrize("sig, cause", [("SIGSEGV", "crash"), ("SIGABRT", "memory")])
def test_a_worker_that_grew_and_died_is_judged_by_how_it_died(sig, cause):
    """Grown past half its memory limit and then dead: an abort is an allocation refused between two looks at its
    size ("memory"); a segmentation fault is a crash whatever it grew first (a recursion 50,000 deep grew the
    worker by 128 MB on the GPU machine before it faulted), and the verdict says how much it grew."""
    w = IsolatedWorker(timeout_s=30, memory_mb=256)
    try:
        with pytest.raises(gw.IsolatedRunError) as info:
            w.call(exec, GROW_THEN_DIE.format(signal=sig), what="the test's code")
        err = info.value
        assert err.cause == cause, str(err)
        if cause == "crash":
            assert "crashed the shader compiler (segmentation fault, after growing by 1" in err.verdict, err.verdict
        else:
            assert "exceeded the 256 MB memory limit (grew by 1" in err.verdict and "then died" in err.verdict, err.verdict
        assert not w.alive
    finally:
        w.close()


def test_what_cannot_be_sent_to_the_worker_is_a_type_error_before_it_starts():
    w = IsolatedWorker()
    with pytest.raises(gw.GrassTypeError, match="picklable"):
        w.call(lambda: 1)
    assert w.starts == 0 and not w.alive


def test_the_limits_refuse_bad_values():
    with pytest.raises(gw.GrassValueError, match="timeout_s must be a number > 0"):
        IsolatedWorker(timeout_s=0)
    with pytest.raises(gw.GrassValueError, match="memory_mb must be a number >= 64"):
        IsolatedWorker(memory_mb=10)


@pytest.mark.slow
def test_a_wind_or_overrides_that_crash_the_compiler_leave_the_field_drawing(monkeypatch):
    """Past the text checks (loosened here, in the kernel only), the compile for drawing is
    tried in the worker first: a WindShaderError / ExerciseShaderError naming the crash, the
    old wind and functions stay, the field steps and the scene renders."""
    monkeypatch.setattr(wgsl_limits, "MAX_NESTING", 10**6)
    scene = gw.GrassScene(gw.Blades.on_plane(256, size=2.0, seed=3), size=(64, 48))
    try:
        calm = "return vec3<f32>(2.0, 0.0, 0.0);"
        scene.field.set_wind_wgsl(calm)
        with pytest.raises(gw.WindShaderError) as info:
            scene.field.set_wind_wgsl(f"return vec3<f32>({NESTED}, 0.0, 0.0);")
        assert "crashed the shader compiler" in str(info.value) and scene.params.wind_wgsl == calm
        ex = gw.exercise("forces")
        with pytest.raises(gw.ExerciseShaderError) as info:
            scene.field.set_function_overrides(FunctionOverrides(CASES["nested 3500 deep"][0], ex.functions))
        assert "crashed the shader compiler" in info.value.reason and scene.field.function_overrides is None
        scene.step(5)
        state = scene.field.read_state()
        assert np.isfinite(state["v2"]).all()
        assert int(grass_mask(scene.render()).sum()) > 100
    finally:
        scene.release()


def test_a_wind_past_the_size_limits_is_refused_at_its_line_and_the_old_wind_stays():
    field = GrassField(gw.Blades.on_plane(64))
    try:
        calm = "return vec3<f32>(2.0, 0.0, 0.0);"
        field.set_wind_wgsl(calm)
        with pytest.raises(gw.WindShaderError) as info:
            field.params.wind_wgsl = "let k = 2.0;\nvar big: array<vec4<f32>, 16777216>;\nreturn big[0].xyz;"
        err = info.value
        assert (err.line, err.column) == (2, 10) and "16,777,216 elements" in str(err), str(err)
        assert field.params.wind_wgsl == calm and field.simulation.wind_body == calm
    finally:
        field.release()


@pytest.mark.slow
def test_a_culling_function_is_compiled_in_the_worker_though_the_simulation_never_calls_it(monkeypatch):
    """frustum_cull is not reached from the simulation's entry point, so a driver would not
    compile it there: the worker's check adds an entry point that calls every replaced
    function. A helper chain the driver cannot finish (text limits loosened here) runs into
    the time limit in the worker, not in the kernel's culling pipeline."""
    monkeypatch.setattr(wgsl_limits, "MAX_INLINED_TERMS", 10**9)
    ex = gw.exercise("culling")
    head = "fn frustum_cull(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, view_proj: mat4x4<f32>, tol: f32) -> bool {"
    helpers = "\n".join(["fn h0(x: f32) -> f32 { return sin(x) * 1.5; }"] + [
        f"fn h{k}(x: f32) -> f32 {{ return h{k - 1}(x) + h{k - 1}(x * 0.5); }}" for k in range(1, 21)])
    code = ex.solution().replace(head, head + "\n    if (h20(tol) > 1e30) { return true; }") + "\n" + helpers + "\n"
    assert head in ex.solution() and code != ex.solution()
    field = GrassField(gw.Blades.on_plane(64))
    worker = shared_worker()
    try:
        field.set_function_overrides(ex.overrides(ex.solution()))  # the probe compiles the solution's functions
        worker.set_limits(timeout_s=4)
        with pytest.raises(gw.ExerciseShaderError) as info:
            field.set_function_overrides(FunctionOverrides(code, ex.functions))
        # The exploding compile runs out of time or, on a quieter machine, into the memory limit
        # first: either way it stopped in the worker, not in the kernel's culling pipeline.
        assert info.value.reason in ("exceeded the 4 s time limit", "exceeded the 1536 MB memory limit"), \
            str(info.value)
        assert field.function_overrides == ex.overrides(ex.solution())  # the functions before stay
        field.step(2)
        assert np.isfinite(field.read_state()["v2"]).all()
    finally:
        worker.set_limits(timeout_s=60)
        field.release()


@pytest.mark.slow
def test_the_function_that_crashes_the_compiler_is_found_by_compiling_each_alone(worker):
    code = CASES["nested 3500 deep"][0]
    line = next(k + 1 for k, row in enumerate(code.split("\n")) if row.startswith("fn wind_force("))
    assert locate_failure(FunctionOverrides(code, FORCES.names), worker) == ("wind_force", line, 1)
    assert locate_failure(FunctionOverrides(FORCES.solution, FORCES.names), worker) is None
    assert grade(FORCES, FORCES.solution, worker=worker).passed


def test_a_worker_without_an_adapter_says_so_and_blames_no_code(monkeypatch):
    monkeypatch.setenv("VK_ICD_FILENAMES", "/nonexistent/icd.json")  # the child's Vulkan finds no driver
    monkeypatch.setenv("VK_DRIVER_FILES", "/nonexistent/icd.json")
    w = IsolatedWorker()
    try:
        with pytest.raises(gw.NoGPUAdapterError):
            w.call(abs, -1)
        assert not w.alive
    finally:
        w.close()
