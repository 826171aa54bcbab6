"""pygfx's DDAA anti-aliasing computed in a compute pass: the same shader code, the same picture.

A GPU renderer made by :func:`grasswidget.gpu.scene.make_renderer` anti-aliases with pygfx's
default post-process, DDAA (directional diffusion): a full-screen fragment pass reading 9 to 40
texels per pixel. On the GPU machine (an H100, a compute chip: only a couple of its clusters run
pixel work, all of them run compute) that pass took 1.4 ms of a 4.6 ms frame at 1920x1080
(``benchmarks/frame_profile.py``). :class:`DDAAPass` runs pygfx's own DDAA code
(``compat.ddaa_fragment_wgsl``, templated with the pass's settings) in a compute shader, one
thread per pixel, into a half-float texture of its own, and then copies that texture into the
renderer's target with a one-texel-per-pixel fragment pass (pygfx's effect chain writes into its
sRGB colour textures, which a compute shader cannot write). The colour goes through a 16-bit
float between the two: pictures agree with pygfx's pass within one level of 255, but for a few
pixels in ten thousand where DDAA's edge search takes its other branch (a texel coordinate that
the rasterizer's interpolation and this shader compute a last bit apart; tests/gpu/test_compute_ddaa.py).

It is a pygfx effect pass like any other: ``renderer.effect_passes`` lists it, ``renderer.ppaa``
reads "ddaa" (the class keeps pygfx's name, so code that saves and restores ``ppaa`` works), and
setting ``renderer.ppaa`` replaces it as it replaces pygfx's own passes.
"""

from __future__ import annotations

import wgpu
from pygfx.renderers.wgpu import DDAAPass as PygfxDDAAPass

from .. import compat
from .adapter import ensure_device

__all__ = ["DDAAPass", "use_compute_ddaa", "WORKGROUP"]

#: Threads per workgroup of the compute shader, (x, y) pixels.
WORKGROUP = (8, 8)

_HEAD = """
struct Varyings {
    texCoord: vec2<f32>,
    position: vec4<f32>,
};

@group(0) @binding(0) var colorTex: texture_2d<f32>;
@group(0) @binding(1) var texSampler: sampler;
@group(0) @binding(2) var resultTex: texture_storage_2d<rgba16float, write>;
"""

_MAIN = """
@compute @workgroup_size({wx}, {wy})
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let size = textureDimensions(colorTex);
    if (gid.x >= size.x || gid.y >= size.y) {{
        return;
    }}
    var varyings: Varyings;
    // What pygfx's full-screen quad gives the fragment of this pixel: its centre, in pixels
    // and in texture coordinates (0..1, +y down).
    varyings.position = vec4<f32>(vec2<f32>(gid.xy) + 0.5, 0.0, 1.0);
    varyings.texCoord = varyings.position.xy * (1.0 / vec2<f32>(size));
    textureStore(resultTex, vec2<i32>(gid.xy), ddaa_at(varyings));
}}
"""

#: (device id, max_edge_iters) -> compute pipeline (templating the WGSL costs more than a frame's host work).
_PIPELINES: dict = {}


def compute_wgsl(effect_pass) -> str:
    """The compute shader: pygfx's DDAA fragment code (for ``effect_pass``'s settings) as a
    function ``ddaa_at``, called once per pixel."""
    code = compat.ddaa_fragment_wgsl(effect_pass)
    code = code.replace(compat.DDAA_FRAGMENT_HEAD, "fn ddaa_at(varyings: Varyings) -> vec4<f32> {")
    return _HEAD + code + _MAIN.format(wx=WORKGROUP[0], wy=WORKGROUP[1])


class DDAAPass(PygfxDDAAPass):
    """pygfx's ``DDAAPass`` (same settings: ``max_edge_iters``, default 5) computed in a compute
    pass, then copied into the effect chain's target (see the module docstring)."""

    # The fragment stage: one texel of the compute result per pixel.
    wgsl = """
        @fragment
        fn fs_main(varyings: Varyings) -> @location(0) vec4<f32> {
            return textureLoad(colorTex, vec2<i32>(varyings.position.xy), 0);
        }
        """

    def __init__(self, *, max_edge_iters=5):
        super().__init__(max_edge_iters=max_edge_iters)
        self._result = None  # (size, texture, view)
        self._bind_group = None  # (source texture, result texture, bind group)
        self._sampler = None

    def _pipeline(self, device):
        key = (id(device), self.max_edge_iters)  # the only setting pygfx's DDAAPass templates
        pipeline = _PIPELINES.get(key)
        if pipeline is None:
            module = device.create_shader_module(code=compute_wgsl(self))
            pipeline = _PIPELINES[key] = device.create_compute_pipeline(
                layout="auto", compute={"module": module, "entry_point": "main"})
        return pipeline

    def _result_view(self, device, size):
        if self._result is None or self._result[0] != size:  # the old one is freed with its last use
            texture = device.create_texture(size=(size[0], size[1], 1), format=wgpu.TextureFormat.rgba16float,
                                            usage=wgpu.TextureUsage.STORAGE_BINDING | wgpu.TextureUsage.TEXTURE_BINDING)
            self._result = (size, texture, texture.create_view())
            self._bind_group = None
        return self._result[1], self._result[2]

    def render(self, command_encoder, color_tex, depth_tex, target_tex):
        """Anti-alias ``color_tex`` into ``target_tex`` (pygfx's effect-pass call)."""
        device = ensure_device()
        w, h = color_tex.size[:2]
        result, result_view = self._result_view(device, (w, h))
        pipeline = self._pipeline(device)
        source = color_tex.texture
        if self._bind_group is None or self._bind_group[:3] != (source, result, pipeline):
            if self._sampler is None:
                self._sampler = device.create_sampler(min_filter="linear", mag_filter="linear")
            group = device.create_bind_group(layout=pipeline.get_bind_group_layout(0), entries=[
                {"binding": 0, "resource": source.create_view(usage=wgpu.TextureUsage.TEXTURE_BINDING)},
                {"binding": 1, "resource": self._sampler},
                {"binding": 2, "resource": result_view},
            ])
            self._bind_group = (source, result, pipeline, group)
        compute_pass = command_encoder.begin_compute_pass()
        compute_pass.set_pipeline(pipeline)
        compute_pass.set_bind_group(0, self._bind_group[3])
        compute_pass.dispatch_workgroups(-(-w // WORKGROUP[0]), -(-h // WORKGROUP[1]), 1)
        compute_pass.end()
        super().render(command_encoder, result_view, depth_tex, target_tex)


def use_compute_ddaa(renderer) -> bool:
    """Replace pygfx's DDAA pass among ``renderer.effect_passes`` (the default post-process
    anti-aliasing on a GPU) by :class:`DDAAPass` with the same ``max_edge_iters``; other passes
    stay as they are, in order. Returns whether one was replaced."""
    passes = list(renderer.effect_passes)
    replaced = False
    for i, step in enumerate(passes):
        if type(step) is PygfxDDAAPass:
            passes[i] = DDAAPass(max_edge_iters=step.max_edge_iters)
            passes[i].enabled = step.enabled
            replaced = True
    if replaced:
        renderer.effect_passes = passes
    return replaced
