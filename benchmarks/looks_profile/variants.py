"""Shader variants for ab.py (text substitutions, other shader files, setups); see ab.py."""
import os
HERE = os.path.dirname(os.path.abspath(__file__))
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

VARIANTS["pervertex"] = {"blade_file": os.path.join(HERE, "blade_render_pervertex_linear.wgsl")}

VARIANTS["pv_noshade"] = {"blade_file": os.path.join(HERE, "blade_render_pervertex_noshade.wgsl")}
VARIANTS["pv_nosrgb"] = {"blade_file": os.path.join(HERE, "blade_render_pervertex_nosrgb.wgsl")}

VARIANTS["main"] = {"blade_file": os.path.join(HERE, "blade_render_main_cad432f.wgsl")}
VARIANTS["looks"] = {}

_DEAD = """    if (varyings.along < -1.0) {
        let q = varyings.world_pos;
        rgb = rgb + vec3<f32>(clump_noise(q.x, q.z, 3.0), simplex_noise2(q.x * 7.0, q.y)) + vec3<f32>(clump_noise(q.y, q.x, 2.0), simplex_noise2(q.z * 5.0, q.y * 3.0));
    }
"""
_LIVE = _DEAD.replace("varyings.along < -1.0", "varyings.along > -1.0")
_AT = "    $$ if teaching_views\n    if (varyings.flat_color.a > 0.5)"
VARIANTS["dead_branch"] = {"blade_file": os.path.join(HERE, "blade_render_main_cad432f.wgsl"), "blade": [(_AT, _DEAD + _AT)]}
VARIANTS["live_branch"] = {"blade_file": os.path.join(HERE, "blade_render_main_cad432f.wgsl"), "blade": [(_AT, _LIVE + _AT)]}
VARIANTS["main_now"] = {"blade_file": os.path.join(HERE, "blade_render_main_4929d74.wgsl")}

# The profile's variants are edits of main's per-fragment shader (cad432f), whatever the tree's own is:
for _name, _v in VARIANTS.items():
    if _name not in ("looks", "main_now") and "blade_file" not in _v:
        _v["blade_file"] = os.path.join(HERE, "blade_render_main_cad432f.wgsl")
VARIANTS["main"] = VARIANTS["base"]
