"""Interleaved, in-process A/B of blade and sky/ground shader variants on the adapter at hand (lavapipe).

    PYTHONPATH=. python benchmarks/looks_profile/ab.py PRESET BLADES CULL ROUNDS VARIANT [VARIANT ...] [--tree NAME=DIR ...]
        [--out PATH]  (default benchmarks/results/looks_profile_ab-<machine>-<date>.json; '-': print only)
    e.g. git archive cad432f grasswidget | tar -x -C /tmp/trees/cad432f  (in the repository), then
    PYTHONPATH=. python benchmarks/looks_profile/ab.py cis565 8192 off 10 main frag_const no_blades --tree main=/tmp/trees/cad432f

PRESET: cis565, meadow (SIZE=WxH in the environment for another size) or default (Blades.on_plane, 640x480);
CULL: on (every test and occlusion) or off (no LOD). Each variant (variants.py) is its own GrassScene whose
shaders get text substitutions, or the blade_render.wgsl of another source tree (``blade_tree``: NAME of a
``--tree NAME=DIR``, a folder holding a ``grasswidget`` package, e.g. from ``git archive REV grasswidget``; it is
rendered with this tree's includes and template values), or a Python ``setup`` (e.g. the field hidden); every
shader is tagged with its variant so that pygfx compiles each apart. Frames (one step and
one render, synced) go round the variants in turns, reversed every round; printed: median process CPU ms and
wall ms per frame, and the median of the per-round ratios to the first variant (quote the CPU ratios on a
loaded machine). Most substitutions were written against the per-fragment shader of main at cad432f
(``main``: ``--tree main=`` a tree of cad432f; ``main_now``: ``--tree main_now=`` one of 4929d74); ``looks`` and
the per-vertex candidates (``pervertex``, ``pv_nosrgb``, ``pv_noshade``) are this tree's own shader and edits of it. This is the scratch profiler behind the
benchmarks/README.md section "The looks' fragment cost on lavapipe".
"""
import os, sys, time, importlib.util
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402  (benchmarks/common.py)
if {"-h", "--help"} & set(sys.argv[1:]):
    print(__doc__)
    sys.exit(0)
import pygfx as gfx
args, trees, out = [], {}, None
_argv = iter(sys.argv[1:])
for _a in _argv:
    if _a == "--out" or _a.startswith("--out="):
        out = _a.split("=", 1)[1] if "=" in _a else next(_argv)
    elif _a == "--tree" or _a.startswith("--tree="):
        _name, _, _dir = (_a.split("=", 1)[1] if "=" in _a and _a.startswith("--tree=") else next(_argv)).partition("=")
        trees[_name] = os.path.join(_dir, "grasswidget", "shaders", "blade_render.wgsl")
        if not _dir or not os.path.isfile(trees[_name]):
            raise SystemExit(f"--tree {_name}={_dir}: no grasswidget/shaders/blade_render.wgsl there")
    else:
        args.append(_a)
if len(args) < 5:
    raise SystemExit("usage: ab.py PRESET BLADES CULL ROUNDS VARIANT [VARIANT ...] [--tree NAME=DIR ...] [--out PATH]")
preset, n, cull, rounds = args[0], int(args[1]), args[2], int(args[3])
names = args[4:]
spec = importlib.util.spec_from_file_location("variants", os.environ.get("VARIANTS", os.path.join(os.path.dirname(os.path.abspath(__file__)), "variants.py")))
V = importlib.util.module_from_spec(spec); spec.loader.exec_module(V)
for _name in names:
    if _name not in V.VARIANTS:
        raise SystemExit(f"unknown variant {_name!r}; variants.py has {', '.join(V.VARIANTS)}")
    _tree = V.VARIANTS[_name].get("blade_tree")
    if _tree is not None and _tree not in trees:
        raise SystemExit(f"variant {_name!r} draws with the blade_render.wgsl of tree {_tree!r}: give --tree {_tree}=DIR")
from grasswidget.gpu.adapter import ensure_device
from grasswidget.gpu.scene import GrassScene
from grasswidget.gpu import shader_classes, sky_ground
from grasswidget.core.shader_files import read_shader
from grasswidget import compat
ensure_device()
import wgpu
from grasswidget.gpu.adapter import ensure_device as _ed
_dev = _ed() if _ed() is not None else None
INC = "{$ include 'grasswidget.blade_math.wgsl' $}"
current = {"name": "base"}
from pygfx.renderers.wgpu import BaseShader
_bs_init = BaseShader.__init__
def _init(self, wobject, **kwargs):
    _bs_init(self, wobject, **kwargs)
    self["variant_tag"] = current["name"]
BaseShader.__init__ = _init
def patch(cls):
    orig = cls.get_code
    def get_code(self):
        name = self["variant_tag"]
        code = orig(self)
        if "blade_tree" in V.VARIANTS[name]:
            code = code.replace(read_shader("blade_render.wgsl"), open(trees[V.VARIANTS[name]["blade_tree"]]).read())
        code = code.replace(INC, read_shader("blade_math.wgsl"))
        kind = "sky" if "sky_ground" in cls.__qualname__.lower() or "SkyGround" in cls.__qualname__ else "blade"
        for old, new in V.VARIANTS[name].get(kind, []):
            if old == "<<APPEND>>":
                code += new
            elif old in code:
                code = code.replace(old, new)
            elif (kind, old) not in V.OPTIONAL:
                raise SystemExit(f"variant {name}: {kind} text not found: {old[:60]!r}")
        return code
    cls.get_code = get_code
patch(shader_classes.BladeRenderShader)
_orig_rs = sky_ground.read_shader
def _sky_read(name):
    code = _orig_rs(name).replace(INC, read_shader("blade_math.wgsl"))
    for old, new in V.VARIANTS[current["name"]].get("sky", []):
        if old == "<<APPEND>>":
            code += new; continue
        if old not in code: raise SystemExit(f"sky text not found {old[:50]!r}")
        code = code.replace(old, new)
    return code
sky_ground.read_shader = _sky_read
scenes = {}
_sb = {}
def sync():
    dev = _sb.get("dev")
    if dev is None:
        dev = _sb["dev"] = scenes_dev[0]
        _sb["buf"] = dev.create_buffer(size=16, usage=wgpu.BufferUsage.COPY_SRC | wgpu.BufferUsage.STORAGE)
    dev.queue.read_buffer(_sb["buf"])
scenes_dev = []
for name in names:
    current["name"] = name
    import grasswidget as gw
    s = GrassScene(gw.Blades.on_plane(n, seed=0), size=(640, 480)) if preset == 'default' else GrassScene.preset(preset, blades=n, seed=0, size=tuple(map(int, os.environ['SIZE'].split('x'))) if os.environ.get('SIZE') else None)
    w, h = s.size
    scenes_dev.append(s.field.stats.device)
    r = gfx.WgpuRenderer(gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm"), pixel_ratio=1, ppaa="none", enable_events=False)
    common.set_culling(s.params, cull, occlusion=cull == "on", compute_raster=False)
    if "setup" in V.VARIANTS[name]:
        V.VARIANTS[name]["setup"](s)
    for _ in range(3):
        s.field.step(1); s.draw_into(r); sync()
    scenes[name] = (s, r)
cpu = {k: [] for k in names}; wall = {k: [] for k in names}
for i in range(rounds):
    order = names if i % 2 == 0 else names[::-1]
    for name in order:
        s, r = scenes[name]
        current["name"] = name
        t0, c0 = time.perf_counter(), time.process_time()
        if not V.VARIANTS[name].get("nostep"): s.field.step(1)
        if not V.VARIANTS[name].get("nodraw"): s.draw_into(r)
        sync()
        cpu[name].append((time.process_time() - c0) * 1e3); wall[name].append((time.perf_counter() - t0) * 1e3)
b = names[0]
print(f"{preset} {n} cull={cull} rounds={rounds}  (median cpu ms, wall ms; ratio = median of per-round ratios to {b})")
for name in names:
    rc = common.median(x / y for x, y in zip(cpu[name], cpu[b]))
    rw = common.median(x / y for x, y in zip(wall[name], wall[b]))
    print(f"{name:>22} cpu {common.median(cpu[name]):7.1f} wall {common.median(wall[name]):7.1f}  ratio cpu {rc:.3f} wall {rw:.3f}", flush=True)
from grasswidget.gpu.adapter import adapter_info
common.save("looks_profile_ab", {"preset": preset, "blades": n, "cull": cull, "rounds": rounds, "variants": names,
                                 "trees": trees, "cpu_ms": cpu, "wall_ms": wall,
                                 "cpu_ratio_to_first": {k: common.median(x / y for x, y in zip(cpu[k], cpu[b])) for k in names},
                                 "wall_ratio_to_first": {k: common.median(x / y for x, y in zip(wall[k], wall[b])) for k in names}},
            adapter_info(), out)
