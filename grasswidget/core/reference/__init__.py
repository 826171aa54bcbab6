"""NumPy reference of the blade physics, the culling tests, the looks and the compute
rasterizer: the spec.

Everything here is vectorised over N blades and imports no GPU code. The WGSL
include ``grasswidget/shaders/blade_math.wgsl`` implements the same functions under the same
names (``shaders/collisions.wgsl`` the loop over the colliders: ``collide_spheres``,
``collision_passes``), so the two can be read side by side: :func:`simulate_step` is
``simulate.wgsl``'s step (fade_collision, tip_step, collision_passes, gain_collision,
validate_finite),
:func:`blade_forces` ``inspect.wgsl``'s. Equation numbers refer to Jahrmann &
Wimmer, "Responsive Real-Time Grass Rendering for General 3D Scenes", I3D 2017.

State dicts hold ``v0, v1, v2, up`` as (N, 3) and ``height, width, orientation,
stiffness`` as (N,) arrays (see :mod:`grasswidget.core.blades`). Computations run in
float64; the GPU runs float32 and agrees to ~1e-5 of the blade height.

Sign conventions chosen here (the sources differ): the width direction ``t1`` is
the tangent basis vector ``e1`` rotated by theta towards ``e2 = cross(e1, up)``, so
on a y-up plane ``t1 = (cos theta, 0, sin theta)``; the front direction is
``f = normalize(cross(up, t1))``.

The reference is a package of modules by subject, all re-exported here (read
``reference.simulate_step`` or ``from grasswidget.core.reference import cull``):
:mod:`~grasswidget.core.reference.physics` (geometry, forces, wind, validation,
collisions, one step, the inspector's forces), :mod:`~grasswidget.core.reference.culling`
(the culling tests, level of detail, occlusion and the depth pyramid),
:mod:`~grasswidget.core.reference.looks` (blade shapes, colours, fog, sky and ground,
shading), :mod:`~grasswidget.core.reference.raster` (the compute rasterizer) and
:mod:`~grasswidget.core.reference.shadows` (the sun, the balls' and the grass' shadows),
:mod:`~grasswidget.core.reference.levels` (the camera-following levels of a field to the horizon), with
:mod:`~grasswidget.core.reference.vectors` (two vector helpers they share).
"""

from __future__ import annotations

from .physics import *  # noqa: F401,F403
from .culling import *  # noqa: F401,F403
from .looks import *  # noqa: F401,F403
from .raster import *  # noqa: F401,F403
from .shadows import *  # noqa: F401,F403
from .levels import *  # noqa: F401,F403
from .vectors import safe_normalize  # noqa: F401
from . import culling, levels, looks, physics, raster, shadows, vectors  # noqa: F401

#: The package's public names: each subject module's own ``__all__`` (what the star imports above
#: bring), and the shared ``safe_normalize`` (vectors' other helpers stay the modules' own).
__all__ = [*physics.__all__, *culling.__all__, *looks.__all__, *raster.__all__, *shadows.__all__, *levels.__all__,
           "safe_normalize"]

