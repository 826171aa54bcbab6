"""Integer ids shared by Python and WGSL (pure Python; no GPU import).

One source: these enums give the ids that the simulation and render shaders
switch on (passed into the WGSL templates as ``wind_field_wave``,
``blade_shape_fold``, ``gravity_mode_point``, ... by
:func:`grasswidget.core.shader_files.template_vars`, the way pygfx passes its marker
enums) and the names that :class:`~grasswidget.GrassParams` accepts
(``WindField.NOISE.label == "noise"``, ``BladeShape.TRIANGLE_TIP.label ==
"triangle-tip"``). To add a wind field: add a member here, its NumPy function in
``core/reference/physics.py`` (and a branch in ``reference.wind_field``), its WGSL twin in
``shaders/blade_math.wgsl`` and a ``case {{ wind_field_<name> }}`` in
``shaders/wind_field.wgsl``; the tests compare the two functions.
"""

from __future__ import annotations

from enum import IntEnum

from ..errors import GrassValueError

__all__ = ["WindField", "BladeShape", "GravityMode", "ColorBy", "LabeledIntEnum"]


class LabeledIntEnum(IntEnum):
    """An IntEnum whose members also have the lowercase, dashed label used by params."""

    @property
    def label(self) -> str:
        """The name as params spell it: ``TRIANGLE_TIP`` -> ``"triangle-tip"``."""
        return self.name.lower().replace("_", "-")

    @classmethod
    def labels(cls) -> tuple[str, ...]:
        """Every label, in id order."""
        return tuple(m.label for m in sorted(cls))

    @classmethod
    def from_label(cls, label: str) -> "LabeledIntEnum":
        """The member with this label; ValueError naming the allowed labels otherwise."""
        for m in cls:
            if m.label == label:
                return m
        raise GrassValueError(f"{cls.__name__} has no member {label!r}; allowed: {', '.join(cls.labels())}")

    @classmethod
    def template_vars(cls, prefix: str) -> dict[str, int]:
        """``{prefix_<label with underscores>: id}`` for the WGSL templates."""
        return {f"{prefix}_{m.name.lower()}": int(m) for m in cls}


class WindField(LabeledIntEnum):
    """Wind fields (``params.wind_field``); ids of ``wind_field.wgsl``'s ``wind_field()`` switch."""

    WAVE = 0
    RADIAL = 1
    VORTEX = 2
    NOISE = 3
    CUSTOM = 4


class BladeShape(LabeledIntEnum):
    """Ribbon shapes of the paper (``params.blade_shape``); ids of ``blade_shape_t()``."""

    QUAD = 0
    TRIANGLE = 1
    QUADRATIC = 2
    TRIANGLE_TIP = 3
    FOLD = 4


class GravityMode(LabeledIntEnum):
    """How environmental gravity is aimed (``params.gravity_mode``); ids of ``environmental_gravity()``."""

    DIRECTION = 0
    POINT = 1


class ColorBy(LabeledIntEnum):
    """How blades are coloured (``params.color_by``); ids of the cull and blade shaders' ``u_cull.color_by``."""

    NATURAL = 0
    LOD = 1
    CULL = 2
