"""Each uniform struct is written once (grasswidget/core/uniform_layouts.py)
and both engines lay it out the same: pygfx's struct (the kernel engine) and the
browser engine's packing put every field at the same byte offset, with the same
type and the same size, and the WGSL reads no field the layout lacks."""

from __future__ import annotations

import re

import numpy as np
import pytest

from grasswidget.core import shader_files, uniform_layouts
from grasswidget.browser import uniforms as browser_uniforms

LAYOUTS = {"u_sim": uniform_layouts.SIM_LAYOUT, "u_cull": uniform_layouts.CULL_LAYOUT}


def _pygfx_fields(layout):
    """{field: (offset, numpy base dtype, element count)} of pygfx's struct for ``layout``."""
    from pygfx.utils import array_from_shadertype

    arr = array_from_shadertype(uniform_layouts.shadertype(layout))
    out = {}
    for name, (dtype, offset) in arr.dtype.fields.items():
        if name.startswith("__"):  # pygfx's explicit padding
            continue
        base = dtype.base if dtype.subdtype else dtype
        count = int(np.prod(dtype.shape)) if dtype.shape else 1
        out[name] = (offset, base.newbyteorder("<").str, count)
    return out, arr.dtype.itemsize


@pytest.mark.parametrize("binding", sorted(LAYOUTS))
def test_both_engines_lay_the_struct_out_alike(binding):
    layout = LAYOUTS[binding]
    kernel, kernel_size = _pygfx_fields(layout)
    browser = browser_uniforms.offsets(layout)
    assert list(kernel) == [name for name, _ in layout] == list(browser)
    for name in browser:
        offset, dtype, count = browser[name]
        assert kernel[name] == (offset, np.dtype(dtype).str, count), name
    assert kernel_size == browser_uniforms.struct_size(layout)


def test_grass_material_struct_is_the_layout_byte_for_byte():
    """The kernel's GrassMaterial (pygfx's base fields opacity and alpha_test included) and
    the browser's blade material struct put every field at the same byte offset."""
    from pygfx.utils import array_from_shadertype

    from grasswidget.gpu.material import GrassMaterial

    arr = array_from_shadertype(GrassMaterial.uniform_type)
    layout = uniform_layouts.GRASS_MATERIAL_LAYOUT
    kernel = {name: arr.dtype.fields[name][1] for name in arr.dtype.names
              if not name.startswith("__") and arr.dtype.fields[name][0].itemsize}
    assert kernel == {name: off for name, (off, _d, _c) in browser_uniforms.offsets(layout).items()}
    assert arr.dtype.itemsize == browser_uniforms.struct_size(layout)
    assert browser_uniforms.GRASS_MATERIAL_LAYOUT is layout


def test_the_engines_import_the_one_layout():
    from grasswidget.gpu import field, simulation

    assert browser_uniforms.SIM_LAYOUT is uniform_layouts.SIM_LAYOUT
    assert browser_uniforms.CULL_LAYOUT is uniform_layouts.CULL_LAYOUT
    assert simulation.SIM_UNIFORM == uniform_layouts.shadertype(uniform_layouts.SIM_LAYOUT)
    assert field.CULL_UNIFORM == uniform_layouts.shadertype(uniform_layouts.CULL_LAYOUT)


def test_browser_struct_text_lists_the_layout():
    for binding, (struct, layout) in (("u_sim", ("SimUniforms", uniform_layouts.SIM_LAYOUT)),
                                      ("u_cull", ("CullUniforms", uniform_layouts.CULL_LAYOUT))):
        text = browser_uniforms.wgsl_struct(struct, layout)
        declared = re.findall(r"^\s*(\w+)\s*:", text, flags=re.M)
        assert declared == [name for name, _ in layout], binding


@pytest.mark.parametrize("binding", sorted(LAYOUTS))
def test_wgsl_reads_only_fields_of_the_layout(binding):
    names = {name for name, _ in LAYOUTS[binding]}
    read = set()
    for name in shader_files.shader_names():
        read |= set(re.findall(rf"\b{binding}\.(\w+)", shader_files.read_shader(name)))
    assert read, f"no shader reads {binding}"
    assert read <= names, f"{binding} fields read by the WGSL but not in the layout: {sorted(read - names)}"


@pytest.mark.parametrize("wgsl, pygfx", [
    ("f32", "f4"), ("i32", "i4"), ("u32", "u4"), ("vec2<f32>", "2xf4"), ("vec4<f32>", "4xf4"),
    ("mat4x4<f32>", "4x4xf4"), ("array<vec4<f32>, 16>", "16*4xf4"),
])
def test_wgsl_types_convert_to_pygfx_shadertypes(wgsl, pygfx):
    assert uniform_layouts.wgsl_shadertype(wgsl) == pygfx


def test_an_unsupported_type_is_refused():
    import grasswidget as gw

    with pytest.raises(gw.GrassValueError, match="vec3"):
        uniform_layouts.wgsl_shadertype("vec3<f32>")
