"""Blade shapes: params.blade_shape drives the material, every shape renders, and
wider shapes cover more pixels."""

import pytest
from traitlets import TraitError

import grasswidget as gw
from conftest import grass_mask
from grasswidget.core.params import BLADE_SHAPES


# Fixtures blades and scene (conftest): few wide upright blades (rest pose, never
# stepped), so that blades rarely overlap.
BLADES = dict(count=40, size=10.0, seed=9, width=(0.3, 0.4), height=(1.5, 2.0))
SCENE = dict(size=(200, 150))


@pytest.fixture(scope="module")
def coverage(scene):
    """Grass pixels per shape (the ground hidden: its far grass beyond the field is green too)."""
    out = {}
    scene.ground.visible = False
    try:
        for shape in BLADE_SHAPES:
            scene.params.blade_shape = shape
            assert scene.field.material.blade_shape == shape  # kept in sync by the field
            img = scene.render()
            out[shape] = int(grass_mask(img).sum())
    finally:
        scene.ground.visible = True
    scene.params.blade_shape = "triangle-tip"
    print("grass pixels per shape:", out)
    return out


def test_every_shape_renders(coverage, scene):
    img = scene.render()
    total = img.shape[0] * img.shape[1]
    for shape, pixels in coverage.items():
        assert pixels > 0.01 * total, shape


def test_quad_covers_more_than_triangle(coverage):
    assert coverage["quad"] > 1.25 * coverage["triangle"]
    # the ribbons narrow in this order: quad > triangle-tip > triangle; quadratic narrows too
    assert coverage["quad"] > coverage["triangle-tip"] > coverage["triangle"]
    assert coverage["quad"] > coverage["quadratic"]


def test_blade_shape_param_validation_and_field_sync():
    p = gw.GrassParams()
    assert p.blade_shape == "triangle-tip"
    with pytest.raises(TraitError, match="blade_shape"):
        p.blade_shape = "hexagon"
    assert p.blade_shape == "triangle-tip"
    b = gw.Blades.on_plane(16, seed=1)
    field = gw.GrassField(b, params=gw.GrassParams(blade_shape="quad"))
    assert field.material.blade_shape == "quad"  # params win at construction
    field.params.blade_shape = "fold"
    assert field.material.blade_shape == "fold"
    # an explicit material shape is kept when the params still have the default
    field2 = gw.GrassField(b, material=gw.GrassMaterial(blade_shape="quadratic"))
    assert field2.params.blade_shape == "quadratic" and field2.material.blade_shape == "quadratic"
