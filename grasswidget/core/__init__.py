"""The pure core: NumPy and traitlets only, no GPU import.

Blades and their packing (:mod:`.blades`), parameters (:mod:`.params`,
:mod:`.enums`), colliders (:mod:`.colliders`), the NumPy reference of every WGSL
function (:mod:`.reference`, the spec), memory limits (:mod:`.memory`), the
uniform layouts of both engines (:mod:`.uniform_layouts`), the WGSL files and
their template variables (:mod:`.shader_files`), the teaching views' colours and
helpers (:mod:`.teaching`), the named presets and view sizes (:mod:`.presets`) and what
Python decides for both engines each frame (:mod:`.engine_inputs`).
"""
