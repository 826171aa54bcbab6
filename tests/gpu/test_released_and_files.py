"""A released GrassScene / GrassField refuses every call with WidgetClosedError, and
``save_png`` refuses a name whose extension it would not honour (lavapipe is enough)."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.gpu.field import GrassField
from grasswidget.gpu.scene import GrassScene


def _public_methods(cls):
    """Every public method the class defines (what a user can call), by name."""
    return sorted(name for name, value in vars(cls).items()
                  if not name.startswith("_") and callable(value)
                  and not isinstance(value, (classmethod, staticmethod, type)))


def _call_with_dummies(method):
    """Call a bound method with None for each required parameter: the closed check comes first."""
    params = [p for p in inspect.signature(method).parameters.values()
              if p.default is inspect.Parameter.empty and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return method(*([None] * len(params)))


def test_a_released_scene_and_field_refuse_every_call():
    scene = GrassScene(gw.Blades.on_plane(64, seed=1), size=(32, 24))
    field = scene.field
    scene.step(2)
    assert scene.render().shape == (24, 32, 4)
    scene.release()
    scene.release()  # a second release does nothing
    assert scene.closed and field.closed
    for obj, cls in ((scene, GrassScene), (field, GrassField)):
        names = [n for n in _public_methods(cls) if n != "release"]
        assert len(names) >= 10, names  # the enumeration finds the API
        for name in names:
            with pytest.raises(gw.WidgetClosedError, match=f"{cls.__name__} is released.*{name}"):
                _call_with_dummies(getattr(obj, name))
    # the widget's own error is also a RuntimeError, as documented
    with pytest.raises(RuntimeError):
        scene.render()


def test_save_png_refuses_an_extension_it_does_not_write(tmp_path):
    scene = GrassScene(gw.Blades.on_plane(64, seed=1), size=(32, 24))
    try:
        for name in ("x.gif", "x.jpg", "x", "x.png.txt"):
            with pytest.raises(gw.GrassValueError, match=r"path must end in \.png.*" + name.replace(".", r"\.")):
                scene.save_png(tmp_path / name)
            assert not (tmp_path / name).exists()
        with pytest.raises(gw.MissingFileError, match="does not exist"):
            scene.save_png(tmp_path / "no-such-folder" / "x.png")
        with pytest.raises(gw.GrassTypeError, match="path must be a file name"):
            scene.save_png(3)
        out = scene.save_png(tmp_path / "X.PNG")  # the extension in any case
        data = (tmp_path / "X.PNG").read_bytes()
        assert out.endswith("X.PNG") and data[:8] == b"\x89PNG\r\n\x1a\n"
        import imageio.v3 as iio

        img = iio.imread(tmp_path / "X.PNG")
        assert img.shape == (24, 32, 4) and np.ptp(img[..., :3]) > 0  # a picture, not a blank
        # the scene keeps working after the refusals
        scene.step(1)
        assert scene.render().shape == (24, 32, 4)
    finally:
        scene.release()
