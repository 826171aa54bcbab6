"""Where the WGSL files live (pure Python; no GPU import).

In a wheel they are packaged as ``grasswidget/shaders``; in a source checkout
they are the top-level ``shaders/`` folder.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["shader_dir", "read_shader"]


def shader_dir() -> Path:
    """The folder holding the WGSL files."""
    here = Path(__file__).resolve().parent
    for candidate in (here / "shaders", here.parent / "shaders"):
        if (candidate / "blade_math.wgsl").is_file():
            return candidate
    raise FileNotFoundError(
        f"grasswidget's WGSL shaders were not found next to {here}; the installation is incomplete"
    )


def read_shader(name: str) -> str:
    """Text of one WGSL file, e.g. ``read_shader("simulate.wgsl")``."""
    return (shader_dir() / name).read_text(encoding="utf-8")
