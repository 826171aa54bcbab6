"""Shader variants for ab.py (text substitutions, another tree's blade_render.wgsl, setups); see ab.py."""
SHADE = """    var rgb = blade_shade(varyings.normal, to_eye, varyings.along, varyings.base_color, glow,
                          varyings.fog, u_material.fog_color.rgb, u_material.light_direction.xyz,
                          u_material.ambient);"""
GLOW = "let glow = backlight(to_eye, normalize(u_material.light_direction.xyz), varyings.along, u_material.translucency);"
OPTIONAL = set()
VARIANTS = {
 "base": {},
 "base2": {},
 "frag_flat": {"blade": [(SHADE, "    var rgb = varyings.base_color;"), (GLOW, "let glow = 0.0;")]},
 "frag_const": {"blade": [(SHADE, "    var rgb = vec3<f32>(0.2, 0.5, 0.1);"), (GLOW, "let glow = 0.0;"),
                          ("out.color = vec4<f32>(srgb2physical(rgb), u_material.opacity);", "out.color = vec4<f32>(rgb, 1.0);")]},
 "no_glow": {"blade": [(GLOW, "let glow = 0.0;")]},
 "vs_noclump": {"blade": [("let clump = clump_noise(v0.x, v0.z, u_material.patch_size);", "let clump = vec2<f32>(0.0);")]},
 "no_sky": {"sky": [("fn fs_main(varyings: Varyings) -> FragmentOutput {\n", "fn fs_main(varyings: Varyings) -> FragmentOutput {\n    if (varyings.ndc.x < 5.0) { var o: FragmentOutput; o.color = vec4<f32>(0.5, 0.6, 0.7, 1.0); return o; }\n")]},
 "no_blades": {"blade": [("varyings.position = vec4<f32>(clip);", "varyings.position = vec4<f32>(clip.x, clip.y, -clip.w - 1.0, clip.w);")]},
}

VS_START = "    let rec = load_blade(blade);\n"
VARIANTS["vs_trivial"] = {"blade": [(VS_START, "    if (blade < 0xffffffffu) { var o: Varyings; o.position = vec4<f32>(2.0, 2.0, 2.0, 1.0); return o; }\n" + VS_START)]}
def _hide(scene):
    scene.field.visible = False
VARIANTS["field_hidden"] = {"setup": _hide}
VARIANTS["peerlike"] = {"blade": VARIANTS["frag_const"]["blade"] + VARIANTS["vs_noclump"]["blade"]}

def _hide_all(scene):
    scene.field.visible = False
    scene.sky_ground.visible = False
VARIANTS["nothing"] = {"setup": _hide_all}
VARIANTS["nothing_nostep"] = {"setup": _hide_all, "nostep": True}
VARIANTS["step_only"] = {"nodraw": True}
VARIANTS["hidden_nostep"] = {"setup": _hide, "nostep": True}

VARIANTS["no_sky"] = {"sky": [("fn fs_main(varyings: Varyings) -> FragmentOutput {", "fn fs_unused(varyings: Varyings) -> FragmentOutput {"),
   ("<<APPEND>>", "\n@fragment\nfn fs_main(varyings: Varyings) -> FragmentOutput {\n    var out: FragmentOutput;\n    out.color = vec4<f32>(0.5, 0.6, 0.7, 1.0);\n    return out;\n}\n")]}

# Per-vertex candidates, as edits of this tree's shader (whose ribbons of 4+ segments are shaded per vertex and
# interpolated in sRGB): every class per vertex, interpolated in linear light ("pervertex"); the same without the
# per-vertex sRGB conversion ("pv_nosrgb": wrong colours, its cost only); the linear one without the shading
# ("pv_noshade": the base colour only).
_EVERY_CLASS = ("$$ if shade_per_vertex\n", "$$ if True\n")
_TO_LINEAR = ("    varyings.color = vec3<f32>(rgb);\n", "    varyings.color = vec3<f32>(srgb2physical(rgb));\n")
_OUT_AS_IS = ("out.color = vec4<f32>(srgb2physical(rgb), u_material.opacity);", "out.color = vec4<f32>(rgb, u_material.opacity);")
_NO_SHADE = ("""    var rgb = blade_shade(world_normal, to_eye, v, base * sunlit.x, glow * sunlit.y,
                          fog_amount(eye_distance, u_material.fog_density), u_material.fog_color.rgb,
                          u_material.light_direction.xyz, u_material.ambient);""", "    var rgb = base;")
VARIANTS["pervertex"] = {"blade": [_EVERY_CLASS, _TO_LINEAR, _OUT_AS_IS]}
VARIANTS["pv_nosrgb"] = {"blade": [_EVERY_CLASS, _OUT_AS_IS]}
VARIANTS["pv_noshade"] = {"blade": [_EVERY_CLASS, _TO_LINEAR, _OUT_AS_IS, _NO_SHADE]}

VARIANTS["looks"] = {}

_DEAD = """    if (varyings.along < -1.0) {
        let q = varyings.world_pos;
        rgb = rgb + vec3<f32>(clump_noise(q.x, q.z, 3.0), simplex_noise2(q.x * 7.0, q.y)) + vec3<f32>(clump_noise(q.y, q.x, 2.0), simplex_noise2(q.z * 5.0, q.y * 3.0));
    }
"""
_LIVE = _DEAD.replace("varyings.along < -1.0", "varyings.along > -1.0")
_AT = "    $$ if teaching_views\n    if (varyings.flat_color.a > 0.5)"
VARIANTS["dead_branch"] = {"blade": [(_AT, _DEAD + _AT)]}
VARIANTS["live_branch"] = {"blade": [(_AT, _LIVE + _AT)]}
VARIANTS["main_now"] = {"blade_tree": "main_now"}  # main at 4929d74 (--tree main_now=DIR)

# The profile's variants are edits of main's per-fragment shader at cad432f (--tree main=DIR), whatever this
# tree's own is; "looks" and the per-vertex candidates above are this tree's shader and edits of it:
for _name, _v in VARIANTS.items():
    if _name not in ("looks", "main_now", "pervertex", "pv_nosrgb", "pv_noshade") and "blade_tree" not in _v:
        _v["blade_tree"] = "main"
VARIANTS["main"] = VARIANTS["base"]

# The sunlight's maths compiled in with shadows off, as before its template switch (main before it: the
# `if (u_material.shadows > 0.0 || ...)` body paid on lavapipe, which runs untaken branches), against
# "looks" (this tree: compiled out while shadows are off); ribbons and sky/ground alike.
from grasswidget.core.shader_files import read_shader as _read_shader

_SUN_INC = "{$ include 'grasswidget.shadows.wgsl' $}"
_SUN_IN = (_SUN_INC, _read_shader("shadows.wgsl").replace("$$ if sunlight\n", "$$ if True\n"))
VARIANTS["sunlight_compiled_in"] = {"blade": [_SUN_IN], "sky": [_SUN_IN]}
