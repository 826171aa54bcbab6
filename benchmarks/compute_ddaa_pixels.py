"""pygfx's fragment DDAA against grasswidget's compute DDAA (gpu/compute_ddaa.py) on this machine's adapter.

    python benchmarks/compute_ddaa_pixels.py [--out PATH] [--png-dir DIR] [--blades 1048576] [--size 1920x1080]

Renders one meadow frame (30 steps in) with no anti-aliasing, pygfx's DDAAPass and the compute one;
prints and writes benchmarks/results/compute_ddaa_pixels-<machine>-<date>.json (or ``--out``: mean
|difference| /255, share of pixels 1 and more than 1 level apart, the largest difference; how much DDAA
itself changed) and, with ``--png-dir``, a crop of the three side by side (``compute_ddaa_crop.png``). tests/gpu/test_compute_ddaa.py holds the same bounds on lavapipe.
"""

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    common.add_out_argument(ap, "compute_ddaa_pixels")
    ap.add_argument("--png-dir", default=None, help="write the side-by-side crop here")
    ap.add_argument("--blades", type=int, default=1 << 20)
    ap.add_argument("--size", default="1920x1080")
    args = ap.parse_args(argv)

    import imageio.v3 as iio
    import numpy as np
    import pygfx as gfx
    from pygfx.renderers.wgpu import DDAAPass as P
    from rendercanvas.offscreen import RenderCanvas

    from grasswidget.gpu.adapter import adapter_info
    from grasswidget.gpu.compute_ddaa import DDAAPass
    from grasswidget.gpu.scene import GrassScene, parse_size

    W, H = parse_size(args.size)
    scene = GrassScene.preset("meadow", blades=args.blades, size=(W, H))
    scene.field.step(30)
    imgs = {}
    for name, passes in (("none", []), ("pygfx", [P()]), ("compute", [DDAAPass()])):
        canvas = RenderCanvas(size=(W, H), pixel_ratio=1)
        r = gfx.WgpuRenderer(canvas, pixel_ratio=1, ppaa="none", enable_events=False)
        r.effect_passes = passes
        canvas.request_draw(lambda: scene.draw_into(r))
        canvas.draw()
        imgs[name] = np.asarray(canvas.draw())[..., :3].astype(np.int16)
    d = np.abs(imgs["compute"] - imgs["pygfx"]).max(-1)
    e = np.abs(imgs["pygfx"] - imgs["none"]).max(-1)
    res = dict(mean_abs=float(np.abs(imgs["compute"] - imgs["pygfx"]).mean()), share_gt1=float((d > 1).mean()),
               share_eq1=float((d == 1).mean()), max=int(d.max()), ddaa_changed_share=float((e > 0).mean()), ddaa_max=int(e.max()))
    common.save("compute_ddaa_pixels", {"blades": args.blades, "size": [W, H], **res}, adapter_info(), args.out)
    if args.png_dir:
        os.makedirs(args.png_dir, exist_ok=True)
        y, x = max(100, H * 2 // 3), max(0, W // 2 - 150)
        crop = np.concatenate([imgs[k][y - 100:y + 100, x:x + 300] for k in ("none", "pygfx", "compute")], 1)
        iio.imwrite(os.path.join(args.png_dir, "compute_ddaa_crop.png"), crop.astype(np.uint8))


if __name__ == "__main__":
    main()
