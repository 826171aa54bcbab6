"""How many blades a culled frame draws against how many its picture shows (occlusion culling's slack).

    python benchmarks/occlusion_shown.py [--preset cis565|default|meadow] [--blades 8192 65536] [--frames 6]
        [--size WxH] [--out PATH]

For each blade count: the preset's scene (``default``: ``Blades.on_plane`` at 640x480, the widget's start),
every culling test and LOD on, the compute rasterizer off (a CPU adapter's default), ``--frames`` frames of
one step and one render each, then, in that state, three renders with occlusion culling off and three with it
on. After the last render of each it reads
the GPU's counts (blades drawn in both occlusion phases, blades occlusion culled) and the renderer's whole
pick texture (``compat.renderer_pick_texture``): the blades the picture shows are the distinct blade ids
written there under the field's object id, every pixel where a blade is the nearest thing.

Occlusion culling is conservative: a blade it culls never shows, so ``shown`` is the same with it on and
off and ``drawn - shown`` is what it could not prove hidden. Printed per row and written to
benchmarks/results/occlusion_shown-<machine>-<date>.json unless ``--out`` says otherwise.
"""

from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import common  # noqa: E402  (benchmarks/common.py)

PICK_OBJECT_BITS = 20  # pygfx packs the object id into the pick value's low 20 bits, then the blade id (26 bits)


def shown_blades(renderer, field, device):
    """Distinct blade ids in the renderer's pick texture under ``field``'s object id (None in a source tree
    older than ``compat.renderer_pick_texture``: its drawn counts are still measured)."""
    import numpy as np

    from grasswidget import compat

    if not hasattr(compat, "renderer_pick_texture"):
        return None
    tex = compat.renderer_pick_texture(renderer)
    w, h = tex.size[0], tex.size[1]
    pitch = -(-w * 8 // 256) * 256
    data = device.queue.read_texture({"texture": tex, "origin": (0, 0, 0), "mip_level": 0},
                                     {"offset": 0, "bytes_per_row": pitch, "rows_per_image": h}, (w, h, 1))
    rows = np.frombuffer(data, np.uint16).reshape(h, pitch // 2)[:, : 4 * w].reshape(h, w, 4).astype(np.uint64)
    value = rows[..., 0] | (rows[..., 1] << 16) | (rows[..., 2] << 32) | (rows[..., 3] << 48)
    mine = (value & ((1 << PICK_OBJECT_BITS) - 1)) == (field.id & ((1 << PICK_OBJECT_BITS) - 1))
    return int(len(np.unique((value[mine] >> PICK_OBJECT_BITS) & ((1 << 26) - 1))))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", choices=common.PRESET_VIEWS, default="cis565")
    ap.add_argument("--blades", type=int, nargs="+", default=[8192, 65536])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--size", default=None, help="WxH (default: the preset's; default preset 640x480)")
    common.add_out_argument(ap, "occlusion_shown")
    a = ap.parse_args(argv)

    from grasswidget.gpu.adapter import adapter_info, ensure_device
    from grasswidget.gpu.scene import make_renderer
    from pygfx.renderers.wgpu import get_shared
    from rendercanvas.offscreen import RenderCanvas

    ensure_device()
    device = get_shared().device
    size = tuple(int(v) for v in a.size.lower().split("x")) if a.size else None
    rows = []
    for n in a.blades:
        scene = common.preset_scene(a.preset, n, size)
        field = scene.field
        field.material.pick_write = True
        w, h = scene.size
        renderer = make_renderer(RenderCanvas(size=(w, h), pixel_ratio=1))
        row = dict(preset=a.preset, blades=n, size=f"{w}x{h}")
        for _ in range(a.frames):  # the wind moves the blades; then both sides see the same state
            field.step(1)
            scene.draw_into(renderer)
        for occlusion in (False, True):
            common.set_culling(scene.params, "on", occlusion=occlusion, compute_raster=False)
            for _ in range(3):  # occlusion's first phase draws the blades seen the frame before
                scene.draw_into(renderer)
            key = "on" if occlusion else "off"
            row[f"drawn_occlusion_{key}"] = int(field.read_draw_args()[:, 1].sum())
            row[f"occluded_occlusion_{key}"] = int(field.read_occluded_count()) if occlusion else 0
            row[f"shown_occlusion_{key}"] = shown_blades(renderer, field, device)
        rows.append(row)
        print(f"{a.preset} {n:>8} blades {w}x{h}: without occlusion culling {row['drawn_occlusion_off']} drawn, "
              f"{row['shown_occlusion_off']} shown; with it {row['drawn_occlusion_on']} drawn "
              f"({row['occluded_occlusion_on']} culled), {row['shown_occlusion_on']} shown", flush=True)
        scene.release()
    common.save("occlusion_shown", dict(preset=a.preset, frames=a.frames, rows=rows), adapter_info(), a.out)


if __name__ == "__main__":
    main()
