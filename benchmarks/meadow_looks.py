"""The meadow's looks measured: the share of bare soil in the picture and the blade density near the camera.

    python benchmarks/meadow_looks.py SHOTS_DIR [--blades 262144 1048576] [--size 1280x720] [--steps 60]
        [--fields horizon square] [--tree NAME=DIR ...] [--out PATH]
    python benchmarks/meadow_looks.py --sheet A.json B.json [...] --sheet-out SHEET.png

For the meadow preset (kernel engine, ``GrassScene.preset("meadow", ...)``) at each blade count and
field (``horizon``: the field to the horizon, the preset's; ``square``: the square field of before,
``horizon=False``), after ``--steps`` simulation steps, from the cameras of :func:`cameras`: "home",
"low" and "top" (``core.camera_presets.camera_preset``, inside the field's orbit limits), eight orbits
all round the home target (home's distance and elevation, azimuths every 45 degrees from home's) and
the home view moved 30 m and 80 m across the field (clamped into the orbit limits). Per camera:

- **soil share** (:func:`soil_share`): the frame is rendered twice with the same state and camera, once
  as it is and once with the soil's colour (``soil_color`` of the sky/ground pass, the bare ground
  under the field) set to a key colour nothing else has (pure blue); every other colour, the far
  grass of the ground included, stays. A pixel *shows bare soil* when one of its channels moves by
  more than :data:`SOIL_STEP` (32 of 255) between the two: blades, sky and far grass do not move at
  all, a pixel of open soil moves by most of the way to the key, and a pixel where the soil is mostly
  blended away (fog, the far grass taking over) moves by less than the step and is not counted. The
  share is the counted pixels over all pixels of the picture.
- **near density** (:func:`near_density`): the blades whose roots lie within :data:`NEAR_RADIUS` (10 m)
  of the camera, horizontally, read back from the GPU's blade buffer after the frame (so whatever the
  layout does per frame counts), over the disc's area (pi r^2, m^2): blades per m^2.

Each picture (the first render) is written to SHOTS_DIR as ``<field>_<blades>_<camera>.png``, and a sheet
of them per blade count (a row per camera, a column per field); pass two source trees with ``--tree``
(``NAME=DIR`` holding a ``grasswidget`` package, as ``presets_ab.py``) to measure both, one child process
each, into ``SHOTS_DIR/NAME/`` with a sheet of both side by side. ``--sheet`` puts the pictures of
earlier results side by side (a column per result and field) without rendering anything. Writes
benchmarks/results/meadow_looks-<machine>-<date>.json unless ``--out`` says otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

#: The key colour the soil is painted with in the second render (sRGB, 0..1): pure blue.
SOIL_KEY = (0.0, 0.0, 1.0, 1.0)
#: A pixel shows bare soil when a channel moves by more than this (of 255) between the two renders.
SOIL_STEP = 32
#: Radius (m, horizontal) of the disc around the camera whose blades count as "near".
NEAR_RADIUS = 10.0
#: The fields a run measures: the preset's field to the horizon and the square field of before.
FIELDS = {"horizon": True, "square": False}
#: The distances (m) the home view is moved across the field.
MOVES = (30.0, 80.0)


def changed_share(plain, keyed, step=SOIL_STEP):
    """Share (0..1) of the pixels whose colour moved by more than ``step`` (0..255) in any of R, G, B
    between two (h, w, 3 or 4) uint8 pictures of the same frame; also the (h, w) bool mask."""
    a = np.asarray(plain)[..., :3].astype(np.int16)
    b = np.asarray(keyed)[..., :3].astype(np.int16)
    if a.shape != b.shape:
        raise ValueError(f"the two pictures differ in size: {a.shape} and {b.shape}")
    mask = np.abs(a - b).max(axis=-1) > int(step)
    return float(mask.mean()), mask


def soil_share(scene):
    """``(share, picture, mask)``: the share of ``scene``'s picture that shows bare soil (the rule in the
    module's docstring), its plain picture (h, w, 4 uint8) and the (h, w) mask of the soil's pixels.
    Nothing advances (two renders of the same state); the soil's colour is restored after."""
    material = scene.sky_ground.material
    soil = tuple(float(v) for v in np.asarray(material.uniform_buffer.data["soil_color"]).reshape(4))
    plain = np.array(scene.render())
    material.set_values({"soil_color": SOIL_KEY})
    try:
        keyed = np.array(scene.render())
    finally:
        material.set_values({"soil_color": soil})
    share, mask = changed_share(plain, keyed)
    return share, plain, mask


def near_density(scene, radius=NEAR_RADIUS):
    """``(blades per m^2, count)`` of the blades whose roots (read back from the GPU's blade buffer) lie
    within ``radius`` metres of the camera, horizontally (the field's own transform applied). For a
    field whose blades are drawn with weights (a field to the horizon made of camera-following levels:
    ``HorizonLayout.table``), only the blades drawn at more than half their width count (weight > 0.5,
    ``reference.blade_weights``): the other levels' blades lying near the camera are not drawn."""
    v0 = np.asarray(scene.field.read_state()["v0"], np.float64)
    m = np.asarray(scene.field.world.matrix, np.float64)
    roots = v0 @ m[:3, :3].T + m[:3, 3]
    cam = np.asarray(scene.camera.world.position, np.float64)
    d2 = (roots[:, 0] - cam[0]) ** 2 + (roots[:, 2] - cam[2]) ** 2
    near = d2 <= radius * radius
    layout = getattr(scene.field.blades, "horizon", None)
    if layout is not None and hasattr(layout, "table"):
        from grasswidget.core.reference.levels import blade_weights

        cam_local = np.linalg.solve(m, np.append(cam, 1.0))[:3]
        near &= blade_weights(v0, cam_local, layout.table()) > 0.5
    count = int(np.count_nonzero(near))
    return count / (math.pi * radius * radius), count


def cameras(scene, home):
    """name -> (position, target) (metres) of the cameras measured: "home" (the preset's own view, as
    the widget opens), then inside the scene's orbit limits "low", "top", "orbit000".."orbit315" (azimuth offset from home's, degrees) and
    "moved30", "moved80" (home's view slid that far along its horizontal forward direction)."""
    from grasswidget.core.camera_presets import camera_preset
    from grasswidget.core.orbit_limits import OrbitLimits, clamp_orbit

    limits = OrbitLimits.for_scene(scene, "grass")
    blades = scene.field.blades
    aspect = scene.size[0] / scene.size[1]
    out = {"home": (np.asarray(home["position"], np.float64), np.asarray(home["target"], np.float64))}
    for name in ("low", "top"):
        view = camera_preset(name, blades.v0, blades.height, home=home, aspect=aspect, limits=limits,
                             horizon=blades.horizon)
        out[name] = (np.asarray(view["position"], np.float64), np.asarray(view["target"], np.float64))
    pos, tgt = (np.asarray(home[k], np.float64) for k in ("position", "target"))
    arm = pos - tgt
    for k in range(8):
        a = math.radians(45.0 * k)
        c, s = math.cos(a), math.sin(a)
        rotated = np.array([c * arm[0] + s * arm[2], arm[1], -s * arm[0] + c * arm[2]])
        out[f"orbit{45 * k:03d}"] = clamp_orbit(tgt + rotated, tgt, limits)
    forward = -arm * np.array([1.0, 0.0, 1.0])
    forward /= max(float(np.linalg.norm(forward)), 1e-9)
    for d in MOVES:
        out[f"moved{d:g}"] = clamp_orbit(pos + d * forward, tgt + d * forward, limits)
    return out


def measure_field(horizon, blades, size, steps, shots):
    """Measure one field (``horizon`` True/False) at ``blades``; pictures into ``shots``; returns its dict."""
    import grasswidget as gw
    from grasswidget.core.presets import preset_field
    from grasswidget.gpu.scene import GrassScene
    from grasswidget.tools.cli import write_image

    field = "horizon" if horizon else "square"
    b, _size, view = preset_field("meadow", blades, seed=0, horizon=horizon)
    scene = GrassScene.preset("meadow", blades=b, size=size, horizon=horizon)
    try:
        home = {"position": view["position"], "target": view["target"], "fov_deg": view["fov_deg"]}
        cams = cameras(scene, home)
        scene.step(steps)
        rows = {}
        for name, (p, t) in cams.items():
            scene.look(position=p, target=t)
            share, picture, _mask = soil_share(scene)
            density, near = near_density(scene)
            path = os.path.join(shots, f"{field}_{blades}_{name}.png")
            write_image(path, picture)
            rows[name] = {"soil_share": share, "near_density_per_m2": density, "near_blades": near,
                          "visible_blades": int(scene.visible_count()),
                          "position": [float(v) for v in p], "target": [float(v) for v in t], "png": path}
            print(f"{field:8s} {blades:8d} {name:9s} soil {100 * share:5.1f} %  near {density:7.1f} /m^2 "
                  f"({near} blades)", flush=True)
    finally:
        scene.release()
    return {"field": field, "blades": blades, "rows": rows, "package": os.path.dirname(gw.__file__)}


def measure(blade_counts, size, steps, fields, shots):
    """Every field at every blade count; returns the result's data (no header)."""
    from grasswidget.gpu.scene import parse_size

    size = parse_size(size)
    os.makedirs(shots, exist_ok=True)
    runs = [measure_field(FIELDS[f], n, size, steps, shots) for n in blade_counts for f in fields]
    return {"size": list(size), "steps": steps, "soil_key": list(SOIL_KEY), "soil_step": SOIL_STEP,
            "near_radius_m": NEAR_RADIUS, "shots": os.path.abspath(shots), "runs": runs}


def _label(img, text):
    """``img`` (h, w, 3) with ``text`` drawn on a white band above it (pygfx-free: a tiny bitmap-less mark)."""
    try:
        from PIL import Image, ImageDraw
    except ImportError:  # pillow absent: no caption
        return img
    band = Image.new("RGB", (img.shape[1], 18), (255, 255, 255))
    ImageDraw.Draw(band).text((4, 3), text, fill=(0, 0, 0))
    return np.concatenate([np.asarray(band), img], axis=0)


def sheet(results, out_png, gap=6):
    """A side-by-side PNG of ``results`` (dicts as :func:`measure` returns, with an optional "name"): per
    blade count a block, a row per camera, a column per result and field; captions give the soil share
    and near density. Returns the path."""
    import imageio.v3 as iio

    columns = []  # (caption prefix, run)
    for res in results:
        for run in res["runs"]:
            columns.append((f"{res.get('name', '')} {run['field']} {run['blades']}".strip(), run))
    cams = []
    for _c, run in columns:
        cams += [c for c in run["rows"] if c not in cams]
    blocks = []
    for name in cams:
        cells = []
        for prefix, run in columns:
            row = run["rows"].get(name)
            if row is None or not os.path.exists(row["png"]):
                continue
            img = iio.imread(row["png"])[..., :3]
            cells.append(_label(img, f"{prefix} {name}: soil {100 * row['soil_share']:.1f} %, "
                                     f"near {row['near_density_per_m2']:.0f}/m2"))
        if not cells:
            continue
        h = max(c.shape[0] for c in cells)
        cells = [np.pad(c, ((0, h - c.shape[0]), (0, 0), (0, 0)), constant_values=255) for c in cells]
        spacer = np.full((h, gap, 3), 255, np.uint8)
        line = [cells[0]]
        for c in cells[1:]:
            line += [spacer, c]
        blocks.append(np.concatenate(line, axis=1))
    width = max(b.shape[1] for b in blocks)
    blocks = [np.pad(b, ((0, gap), (0, width - b.shape[1]), (0, 0)), constant_values=255) for b in blocks]
    iio.imwrite(out_png, np.concatenate(blocks, axis=0), extension=".png")
    print("wrote", out_png, flush=True)
    return out_png


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("shots", nargs="?", help="folder for the pictures and sheets (not results/)")
    ap.add_argument("--blades", type=int, nargs="+", default=[1 << 18, 1 << 20])
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--fields", nargs="+", choices=sorted(FIELDS), default=["horizon", "square"])
    ap.add_argument("--tree", action="append", default=[], help="NAME=DIR holding a grasswidget package (repeatable)")
    ap.add_argument("--sheet", nargs="+", default=None, metavar="RESULT.json",
                    help="put the pictures of these results side by side (no rendering)")
    ap.add_argument("--sheet-out", default=None, help="the PNG --sheet writes (default: meadow_looks_sheet.png "
                                                      "in the first result's shots folder)")
    common.add_out_argument(ap, "meadow_looks")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.sheet:
        results = []
        for path in args.sheet:
            with open(path) as f:
                res = json.load(f)
            name = os.path.splitext(os.path.basename(path))[0]
            # a run of --tree holds one result per tree
            for one in res.get("trees", [res]):
                one.setdefault("name", name)
                results.append(one)
        sheet(results, args.sheet_out or os.path.join(results[0]["shots"], "meadow_looks_sheet.png"))
        return 0
    if not args.shots:
        ap.error("the shots folder is required (or --sheet)")
    if args.child:
        common.emit(measure(args.blades, args.size, args.steps, args.fields, args.shots))
        return 0
    from grasswidget.gpu.adapter import adapter_info

    if args.tree:
        trees = common.parse_trees(args.tree, minimum=1)
        results = []
        for name, folder in trees:
            child = [os.path.abspath(__file__), os.path.join(os.path.abspath(args.shots), name), "--child",
                     "--size", args.size, "--steps", str(args.steps), "--blades", *map(str, args.blades),
                     "--fields", *args.fields]
            results.append(dict(common.run_in_tree(folder, child), name=name, tree=os.path.abspath(folder)))
        data = {"trees": results}
    else:
        results = [measure(args.blades, args.size, args.steps, args.fields, args.shots)]
        data = results[0]
    sheet(results, os.path.join(args.shots, "meadow_looks_sheet.png"))
    common.save("meadow_looks", data, adapter_info(), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
