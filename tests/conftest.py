import os
import tempfile

# The Vulkan loader complains on every start without a private runtime dir.
if not os.environ.get("XDG_RUNTIME_DIR"):
    d = os.path.join(tempfile.gettempdir(), f"xdg-{os.getuid()}")
    os.makedirs(d, mode=0o700, exist_ok=True)
    os.environ["XDG_RUNTIME_DIR"] = d

import numpy as np  # noqa: E402
import pytest  # noqa: E402


# ---------------------------------------------------------------- test times, as they go
#
# Each test's wall time (set-up + call + tear-down) is appended to a file the moment it ends, so
# a run that is killed part-way still tells where its time went (``--durations`` prints only at
# the end). The file is ``$GW_TEST_TIMES`` (default: ``.test-times.log`` in the checkout's root),
# emptied when a run starts; one line per test: total, set-up, call, tear-down seconds, the
# 1-minute load average when it ended, the outcome and the test's id.

#: The file's path (set when the run is configured) and the phases of the tests still running.
_TEST_TIMES = {"path": os.devnull, "running": {}}


def _is_worker(config) -> bool:
    """Whether this process is one of pytest-xdist's workers (the controller writes the times file)."""
    return hasattr(config, "workerinput")


def pytest_configure(config):
    if not _is_worker(config) and not config.option.collectonly:
        _TEST_TIMES["path"] = os.environ.get("GW_TEST_TIMES") or os.path.join(str(config.rootpath), ".test-times.log")


def pytest_sessionstart(session):
    if not _is_worker(session.config) and not session.config.option.collectonly:  # --collect-only times nothing
        with open(_TEST_TIMES["path"], "w") as f:
            f.write("# total_s setup_s call_s teardown_s load1 outcome test\n")


def pytest_runtest_logreport(report):
    phases = _TEST_TIMES["running"].setdefault(report.nodeid, {"outcome": "passed"})
    phases[report.when] = report.duration
    if report.failed:
        phases["outcome"] = "failed" if report.when == "call" else f"{report.when}-error"
    elif report.skipped:
        phases["outcome"] = "skipped"
    if report.when != "teardown":
        return
    del _TEST_TIMES["running"][report.nodeid]
    setup, call, teardown = (phases.get(w, 0.0) for w in ("setup", "call", "teardown"))
    with open(_TEST_TIMES["path"], "a") as f:
        f.write(f"{setup + call + teardown:8.2f} {setup:7.2f} {call:7.2f} {teardown:7.2f} "
                f"{os.getloadavg()[0]:5.1f} {phases['outcome']:<13} {report.nodeid}\n")


# ---------------------------------------------------------------- two workers (pytest-xdist)
#
# A whole run (``./run.sh test``, ``pytest`` with no file named) uses two pytest-xdist workers
# (``-n auto --dist loadscope --no-loadscope-reorder`` where no ``-n`` is given and pytest-xdist, of the
# ``test`` extra, is installed; without it the run is serial, as before). Every test that drives
# a real browser (tests/e2e) is one unit of work that one worker runs first, one test after the other
# in collection order, with the session's one JupyterLab and Chromium, as in a serial run; the other
# worker takes the remaining modules, each module whole (its module fixtures, GPU fields and scenes,
# are built once), and the first worker joins it when the browser tests are done. A run of files or
# node ids only, or of tests/e2e alone, uses no workers: nothing to share out. ``-n 0`` runs
# everything in one process; ``PYTEST_XDIST_AUTO_NUM_WORKERS=N`` picks N workers.

_HERE = os.path.dirname(os.path.abspath(__file__))
_E2E = os.path.join(_HERE, "e2e")

#: The unit of work of the tests that drive a browser: one worker runs them all, in order.
E2E_UNIT = "tests/e2e"
#: The browser tests that need no JupyterLab (marimo's servers, Notebook 7 and Voila of their own, and
#: a Chromium): a second unit of work, handed out second, so that the other worker runs them beside the
#: first unit (about 140 s of the 670 s of tests/e2e on CI's 2 cores; the two workers then end together).
E2E_SECOND_UNIT = "tests/e2e (own servers)"
E2E_SECOND_MODULES = ("test_marimo.py", "test_compare_marimo_page.py", "test_front_ends.py")

#: Set on the controller's config when this file chose how the run is shared out.
_SHARED = pytest.StashKey[bool]()


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config):
    """``-n auto --dist loadscope --no-loadscope-reorder`` unless the command line says ``-n``
    (before pytest-xdist reads them; nothing where pytest-xdist is not installed). Never in a worker, nor
    in a pytest that a worker's test starts (``PYTEST_XDIST_WORKER`` is set there): a worker starts no workers."""
    if _is_worker(config) or os.environ.get("PYTEST_XDIST_WORKER"):
        return
    if getattr(config.option, "numprocesses", False) is None and not config.option.collectonly:
        config.option.numprocesses = "auto"
        if config.option.dist == "no":
            config.option.dist = "loadscope"
            config.option.loadscopereorder = False
            config.stash[_SHARED] = True


@pytest.hookimpl(optionalhook=True)  # pytest-xdist's hook: unknown where it is not installed
def pytest_xdist_auto_num_workers(config):
    """Workers for ``-n auto``: 2 (or the CPU count if smaller) for a run that names a folder other
    than tests/e2e (or nothing: the whole suite), none for a run of files or node ids only, or of tests/e2e alone."""
    env = os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS")
    if env:
        return int(env)
    args = [a for a in config.args if not a.startswith("-")] or [str(config.rootpath)]
    folders = [os.path.abspath(a) for a in args if "::" not in a and os.path.isdir(a)]
    spread = [f for f in folders if f != _E2E and not f.startswith(_E2E + os.sep)]
    if not spread:
        return 0
    return max(0, min(2, os.cpu_count() or 1))


@pytest.hookimpl(optionalhook=True, tryfirst=True)
def pytest_xdist_make_scheduler(config, log):
    """The units of work: tests/e2e as one, every other module as one (pytest-xdist's ``loadscope``
    with its scope so widened; its ``loadgroup`` cannot name groups under pytest 9)."""
    if not config.stash.get(_SHARED, False):
        return None
    from xdist.scheduler import LoadScopeScheduling

    class E2EThenModules(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            path = nodeid.split("::", 1)[0]
            if not path.startswith(E2E_UNIT + "/"):
                return path
            return E2E_SECOND_UNIT if path.rsplit("/", 1)[-1] in E2E_SECOND_MODULES else E2E_UNIT

    return E2EThenModules(config, log)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """Tell each worker how the run is shared out (its options come from the command line alone)."""
    node.workerinput["gw_shared"] = node.config.stash.get(_SHARED, False)


def _in_e2e(item) -> bool:
    return str(item.path).startswith(_E2E + os.sep)


def pytest_collection_modifyitems(config, items):
    """In a worker of a run shared out here: the browser tests first (the first two units of work
    handed out: they are the longest part of a run), those of :data:`E2E_UNIT` before those of
    :data:`E2E_SECOND_UNIT`, the rest in collection order."""
    if _is_worker(config) and config.workerinput.get("gw_shared"):
        items.sort(key=lambda item: (not _in_e2e(item), item.path.name in E2E_SECOND_MODULES))


def grass_mask(img):
    """Pixels that are grass: green clearly dominates red and blue."""
    rgb = img[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (g > r + 8) & (g > b + 8)


def hue_degrees(img):
    """Each pixel's hue (HSV, degrees 0..360) of an (..., 3+) uint8 picture; grey pixels get 0."""
    rgb = img[..., :3].astype(np.float64)
    mx, mn = rgb.max(axis=-1), rgb.min(axis=-1)
    c = np.maximum(mx - mn, 1e-9)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hue = np.where(mx == r, ((g - b) / c) % 6, np.where(mx == g, (b - r) / c + 2, (r - g) / c + 4))
    return np.where(mx > mn, hue * 60.0, 0.0)


def shaded_grass_mask(img):
    """Pixels that are grass, lit or in the sunlight's shade: green is the largest channel, leads
    blue by more than 4 and the hue is a grass green (68..160 degrees; the bare ground's khaki
    #787a4e is 62, soil is 20..50).

    ``grass_mask`` asks green to lead red and blue by 8 levels, which the grass' own shade (the
    sunlight, ``GrassParams.shadows``: on by default on a GPU adapter) fails near the roots, where
    a blade is 20-30 levels bright; this mask counts those pixels by their colour, not their
    brightness (measured: the same default view is 0.75 grass under it with the sunlight on or off,
    on lavapipe and on an H200, where ``grass_mask`` gives 0.75 and 0.55)."""
    rgb = img[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hue = hue_degrees(img)
    return (g >= r) & (g > b + 4) & (hue > 68.0) & (hue < 160.0)


def sky_mask(img):
    """Pixels of the light-blue sky background."""
    rgb = img[..., :3].astype(np.int32)
    return (rgb[..., 2] > 180) & (rgb[..., 2] > rgb[..., 1]) & (rgb[..., 1] > rgb[..., 0])


@pytest.fixture(scope="session")
def small_blades():
    import grasswidget as gw

    return gw.Blades.on_plane(2048, seed=3)


# ---------------------------------------------------------------- shared GPU fixtures
#
# A test module says what it needs with module-level dicts and takes these fixtures
# (one field or scene per module, built on first use):
#   BLADES = dict(count=..., size=..., seed=..., ...)  -> ``blades`` (Blades.on_plane(**BLADES));
#            without BLADES, ``blades`` is the session's ``small_blades``
#   FIELD_PARAMS = dict(...)                           -> ``field`` (GrassField(blades, GrassParams(**FIELD_PARAMS)))
#                                                         and ``fresh`` (that field at rest, restored after the test)
#   SCENE = dict(size=..., params=dict(...))           -> ``scene`` (GrassScene(blades, size, GrassParams(**params)))
#   SCENE = dict(preset=..., blades=..., size=..., seed=...)  -> ``scene`` (GrassScene.preset(...))


def _module_spec(request, name, default=None):
    return dict(getattr(request.module, name, default) or {})


@pytest.fixture(scope="module")
def blades(request):
    """The module's blades: ``Blades.on_plane(**BLADES)``, or ``small_blades``."""
    import grasswidget as gw

    spec = _module_spec(request, "BLADES")
    return gw.Blades.on_plane(**spec) if spec else request.getfixturevalue("small_blades")


@pytest.fixture(scope="module")
def field(request, blades):
    """A GrassField of the module's blades with ``GrassParams(**FIELD_PARAMS)``; its GPU buffers
    are freed after the module."""
    import grasswidget as gw

    field = gw.GrassField(blades, params=gw.GrassParams(**_module_spec(request, "FIELD_PARAMS")))
    yield field
    field.release()


@pytest.fixture
def fresh(request, field):
    """The module's field at rest with no colliders; afterwards every parameter is back
    to ``FIELD_PARAMS`` (or its default), the colliders cleared and the field at rest."""
    import grasswidget as gw

    field.reset()
    field.colliders.clear()
    yield field
    defaults = gw.GrassParams(**_module_spec(request, "FIELD_PARAMS"))
    for name in defaults.trait_names():
        if getattr(field.params, name) != getattr(defaults, name):
            setattr(field.params, name, getattr(defaults, name))
    field.colliders.clear()
    field.reset()


@pytest.fixture(scope="module")
def scene(request):
    """The module's GrassScene, from its ``SCENE`` dict (a preset, or the module's
    ``blades`` at ``size`` with ``params``); its GPU buffers are freed after the module."""
    import grasswidget as gw

    spec = _module_spec(request, "SCENE")
    if "preset" in spec:
        scene = gw.GrassScene.preset(spec.pop("preset"), **spec)
    else:
        params = spec.pop("params", None)
        scene = gw.GrassScene(request.getfixturevalue("blades"),
                              params=gw.GrassParams(**params) if params else None, **spec)
    yield scene
    scene.release()


#: View size of the test widgets (CSS pixels).
WIDGET_SIZE = (160, 120)




class TickingWall:
    """A simulated wall clock for GrassWidget's real-time clock: each reading is
    ``tick`` seconds after the one before (``advance(s)`` adds more)."""

    def __init__(self, tick=0.0):
        self.t = 1000.0
        self.tick = tick

    def __call__(self):
        self.t += self.tick
        return self.t

    def advance(self, seconds):
        self.t += seconds


@pytest.fixture
def widget():
    """A GrassWidget of 1024 blades at WIDGET_SIZE, closed after the test. Its
    simulation clock reads a TickingWall that moves one nominal frame interval
    (1 / max_fps) per reading, so each frame drawn while playing advances exactly
    ``steps_per_frame`` fixed steps (the clock reads the wall once per frame)."""
    import grasswidget as gw

    w = gw.GrassWidget(blades=1024, size=WIDGET_SIZE)
    w.view.clock.now = TickingWall(1.0 / w.max_fps)
    yield w
    w.close()


@pytest.fixture
def ctrl_c_enabled():
    """Ctrl-C (SIGINT) handled as in an interactive Python for the test: a process started in the
    background by a non-interactive shell (``cmd &``, some CI runners) inherits SIGINT ignored,
    and grasswidget rightly holds back nothing then (``core.limits.hold_interrupts``)."""
    import signal

    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


def param_extremes():
    """(trait, value) for both ends of every float trait of GrassParams, and for every vector trait
    its limit along every axis (1e300 where it has none) and, where a zero vector is refused, the
    smallest non-zero direction: what the finite-state tests run the physics at (pure and GPU)."""
    import grasswidget as gw
    from grasswidget.core.params import RangedFloat, Vec3

    p = gw.GrassParams()
    out = []
    for name in sorted(p.trait_names()):
        trait = p.traits()[name]
        if isinstance(trait, RangedFloat):
            out += [(name, trait.lo), (name, trait.hi)]
        elif isinstance(trait, Vec3):
            big = trait.limit if trait.limit is not None else 1e300
            out += [(name, (big, -big, big)), (name, (-big, 0.0, 0.0))]
            if trait.nonzero:
                out.append((name, (0.0, -1e-300, 0.0)))
    return out


def _run_compute(code, words_in, words_out, n):
    """Run WGSL ``code`` (entry point ``main``, workgroup 64, bindings 0: ``array<u32>``
    in, 1: ``array<u32>`` out) over n items on the project's device; returns the out words.
    Both buffers are destroyed before it returns (or raises)."""
    import wgpu

    from grasswidget.gpu.adapter import ensure_device

    device = ensure_device()
    usage = wgpu.BufferUsage
    data = np.ascontiguousarray(words_in, np.uint32)
    b_in = device.create_buffer_with_data(data=data.tobytes() or b"\0\0\0\0", usage=usage.STORAGE)
    b_out = device.create_buffer(size=max(4 * words_out * n, 4), usage=usage.STORAGE | usage.COPY_SRC)
    try:
        return _dispatch(device, code, b_in, b_out, words_out, n)
    finally:
        b_in.destroy()
        b_out.destroy()


def _dispatch(device, code, b_in, b_out, words_out, n):
    """One dispatch of ``code`` over n items reading ``b_in`` and writing ``b_out``; its out words."""
    pipeline = device.create_compute_pipeline(
        layout="auto", compute={"module": device.create_shader_module(code=code), "entry_point": "main"}
    )
    group = device.create_bind_group(
        layout=pipeline.get_bind_group_layout(0),
        entries=[{"binding": 0, "resource": {"buffer": b_in}}, {"binding": 1, "resource": {"buffer": b_out}}],
    )
    encoder = device.create_command_encoder()
    cpass = encoder.begin_compute_pass()
    cpass.set_pipeline(pipeline)
    cpass.set_bind_group(0, group)
    cpass.dispatch_workgroups(-(-n // 64))
    cpass.end()
    device.queue.submit([encoder.finish()])
    return np.frombuffer(device.queue.read_buffer(b_out), np.uint32)[: words_out * n].reshape(n, words_out)


@pytest.fixture(scope="session")
def run_compute():
    """``run_compute(code, words_in (n, k) uint32, words_out, n) -> (n, words_out) uint32``:
    a small compute harness on the project's GPU device (lavapipe on CPU machines).
    The WGSL reads ``harness_in: array<u32>`` (binding 0) and writes ``harness_out:
    array<u32>`` (binding 1) with ``@workgroup_size(64)``."""
    return _run_compute


HARNESS_BINDINGS = """
@group(0) @binding(0) var<storage, read> harness_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> harness_out: array<u32>;
"""


def node_executable() -> str:
    """The Node.js binary that runs engine.js's rules outside a browser. ``run.sh`` installs
    Debian's ``nodejs``, so a missing node is a broken set-up: the test fails, never skips."""
    import shutil

    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        pytest.fail("Node.js is not installed: ./run.sh test installs Debian's nodejs package")
    return node


# ---------------------------------------------------------------- what packaging tests need
#
# Building the wheel or the sdist needs the build backend (hatchling, in the ``test`` extra: the
# tests build with --no-build-isolation, so nothing is fetched), and installing the built wheel
# into a fresh environment needs a package index for its dependencies. Where either is missing
# (the GPU machine: no network, see tests/run_on_gpu.sh) those tests skip, saying why.

_INDEX = {}


def require_build_backend():
    """Skip the calling test when the build backend (hatchling) cannot be imported."""
    import importlib.util

    if importlib.util.find_spec("hatchling") is None:
        pytest.skip("the build backend hatchling is not installed (pip install -e .[test] installs it; "
                    "with no network to fetch it, the package cannot be built here)")


def require_package_index():
    """Skip the calling test when pip cannot reach a package index (no network): asks the index pip is
    configured with for one of the package's dependencies (hsluv), once per session, 5 s at most."""
    import subprocess
    import sys

    if "reason" not in _INDEX:
        try:
            out = subprocess.run([sys.executable, "-m", "pip", "index", "versions", "hsluv", "--timeout", "5",
                                  "--retries", "0", "--disable-pip-version-check"],
                                 capture_output=True, text=True, timeout=60)
            _INDEX["reason"] = None if out.returncode == 0 else (out.stderr.strip().splitlines() or ["no answer"])[-1]
        except (OSError, subprocess.TimeoutExpired) as e:
            _INDEX["reason"] = str(e)
    if _INDEX["reason"]:
        pytest.skip(f"no package index reachable (no network?) for the wheel's dependencies: {_INDEX['reason']}")


# ---------------------------------------------------------------- one state, the same picture
#
# On a CPU adapter (lavapipe) two renders of one state are the same bytes. On a GPU they may
# differ in a few pixels: the culling pass appends the blades it keeps with an atomic counter, so
# their draw order follows whichever workgroup finished first, and where two blades' fragments tie
# in depth the later one wins. Measured on an H200 (2026-11-28): 0, 2, 3 and 8 pixels of 14,400 to
# 120,000 between repeated renders of one state (at most 0.06 %).

#: Share of pixels that may differ between two renders of one state on a GPU adapter (0 on a CPU adapter).
GPU_REPEAT_PIXEL_SHARE = 0.002


def assert_same_picture(a, b, what="the picture"):
    """``a`` and ``b`` (renders of one state) are equal: byte for byte on a CPU adapter; on a GPU in
    all but GPU_REPEAT_PIXEL_SHARE of the pixels (the draw order of tied blades, see above)."""
    from grasswidget.gpu.adapter import is_cpu_adapter

    a, b = np.asarray(a)[..., :3], np.asarray(b)[..., :3]
    assert a.shape == b.shape, (what, a.shape, b.shape)
    differing = int(np.any(a != b, axis=-1).sum())
    allowed = 0 if is_cpu_adapter() else int(GPU_REPEAT_PIXEL_SHARE * a.shape[0] * a.shape[1])
    assert differing <= allowed, f"{what}: {differing} pixels differ (at most {allowed} on this adapter)"


def save_test_picture(name, img):
    """Write ``img`` as ``$GW_TEST_PICTURES/<name>.png`` when that variable names a folder (tests/run_on_gpu.sh
    sets it, so that the GPU machine's pictures come back to be looked at); otherwise nothing."""
    folder = os.environ.get("GW_TEST_PICTURES")
    if not folder:
        return None
    import imageio.v3 as iio

    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, f"{name}.png")
    iio.imwrite(path, np.ascontiguousarray(np.asarray(img)[..., :3], np.uint8))
    return path
