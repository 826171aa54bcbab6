"""The WGSL files of the package (pure Python; no GPU import).

They live in ``grasswidget/shaders/`` and ship inside the wheel and the sdist;
the same folder serves a source checkout and an installed copy.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

__all__ = ["shader_dir", "read_shader", "shader_names"]


def shader_dir() -> Path:
    """The folder holding the WGSL files (``grasswidget/shaders``)."""
    return Path(str(resources.files("grasswidget") / "shaders"))


def shader_names() -> list[str]:
    """File names of every WGSL file of the package, sorted."""
    return sorted(p.name for p in shader_dir().glob("*.wgsl"))


def read_shader(name: str) -> str:
    """Text of one WGSL file, e.g. ``read_shader("simulate.wgsl")``."""
    path = shader_dir() / name
    if not path.is_file():
        raise FileNotFoundError(f"grasswidget has no shader {name!r} in {shader_dir()}; the installation is incomplete")
    return path.read_text(encoding="utf-8")
