"""pygfx's fragment DDAA against grasswidget's compute DDAA (gpu/compute_ddaa.py) on this machine's adapter.

    python benchmarks/compute_ddaa_pixels.py --out-dir DIR [--blades 1048576] [--size 1920x1080]

Renders one meadow frame (30 steps in) with no anti-aliasing, pygfx's DDAAPass and the compute one;
prints and writes ``compute_ddaa_pixels.json`` (mean |difference| /255, share of pixels 1 and more than 1
level apart, the largest difference; how much DDAA itself changed) and a crop of the three side by side
(``compute_ddaa_crop.png``). tests/gpu/test_compute_ddaa.py holds the same bounds on lavapipe.
"""

import argparse
import json
import os

import imageio.v3 as iio
import numpy as np
import pygfx as gfx
from pygfx.renderers.wgpu import DDAAPass as P
from rendercanvas.offscreen import RenderCanvas

from grasswidget.gpu.compute_ddaa import DDAAPass
from grasswidget.gpu.scene import GrassScene, parse_size

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--blades", type=int, default=1 << 20)
    ap.add_argument("--size", default="1920x1080")
    args = ap.parse_args()
    out = args.out_dir
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
    print(json.dumps(res))
    json.dump(res, open(os.path.join(out, "compute_ddaa_pixels.json"), "w"))
    y, x = max(100, H * 2 // 3), max(0, W // 2 - 150)
    crop = np.concatenate([imgs[k][y - 100:y + 100, x:x + 300] for k in ("none", "pygfx", "compute")], 1).astype(np.uint8)
    iio.imwrite(os.path.join(out, "compute_ddaa_crop.png"), crop)


if __name__ == "__main__":
    main()
