"""A private ``XDG_RUNTIME_DIR`` for processes started without one.

The Vulkan loader (under wgpu) prints ``XDG_RUNTIME_DIR is invalid or not set``
several times when that variable is missing, as it is under plain ``python``,
cron, docker exec or a Jupyter kernel started by a service. ``import grasswidget``
calls :func:`ensure_runtime_dir`, which, only when the variable is unset or names
no usable directory, points it at a directory of this user's own with mode 0700
(the XDG spec's requirement) before any Vulkan instance exists. A variable that
is already set to a good directory is left alone.
"""

from __future__ import annotations

import os
import stat
import tempfile

__all__ = ["ensure_runtime_dir"]


def _usable(path) -> bool:
    """An existing directory owned by this user, mode 0700 (no access for others)."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return (stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid()
            and stat.S_IMODE(st.st_mode) & 0o077 == 0 and os.access(path, os.W_OK | os.X_OK))


def ensure_runtime_dir() -> str | None:
    """Set ``os.environ["XDG_RUNTIME_DIR"]`` to a private 0700 directory when it is
    unset or unusable; return the directory in use (None on a system without
    ``os.getuid``, e.g. Windows, where the loader does not ask for it)."""
    if not hasattr(os, "getuid"):
        return None
    current = os.environ.get("XDG_RUNTIME_DIR")
    if current and os.path.isdir(current):
        return current  # the user's own choice (or the session's): leave it
    path = os.path.join(tempfile.gettempdir(), f"grasswidget-runtime-{os.getuid()}")
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    except OSError:
        path = None
    if path is None or not _usable(path):
        # Someone else's, a file, or a too-open directory: never use it; make a fresh one.
        path = tempfile.mkdtemp(prefix="grasswidget-runtime-")  # mkdtemp creates it 0700
    os.environ["XDG_RUNTIME_DIR"] = path
    return path
