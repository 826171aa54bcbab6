"""No module of ours reads another's private attributes, and
no test reaches into a private name.

An ast walk over grasswidget/ and tests/: ``x._name`` (and ``getattr(x, "_name")``,
``hasattr``/``setattr``/``delattr`` the same way) is allowed only where ``x`` is
``self``, ``cls`` or ``super()``, or where ``_name`` is defined in the same file
(a module's own helpers and its own classes' attributes). Private API of pygfx,
wgpu, jupyter-rfb, rendercanvas and ipykernel lives in grasswidget/compat.py,
whose contract test (tests/test_compat.py) must touch those names to check them.
"""

from __future__ import annotations

import ast
from pathlib import Path

import grasswidget as gw

PACKAGE = Path(gw.__file__).parent
TESTS = Path(__file__).parent
#: The only files that may touch another package's private names: the compat module
#: and the test that checks every one of its uses against the installed packages.
ALLOWED_FILES = {PACKAGE / "compat.py", TESTS / "test_compat.py"}
ATTR_FUNCTIONS = {"getattr", "hasattr", "setattr", "delattr"}


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _own_names(tree) -> set:
    """Private names a file defines: functions, classes, stored attributes, names, class attributes."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "setattr":
            if len(node.args) >= 2 and isinstance(node.args[1], ast.Constant):
                names.add(node.args[1].value)
    return {n for n in names if isinstance(n, str) and _private(n)}


def _is_self(node) -> bool:
    if isinstance(node, ast.Name) and node.id in ("self", "cls"):
        return True
    return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "super"


def private_reaches(path: Path) -> list[str]:
    """'file:line: expression' for each reach into a private name that ``path`` does not own."""
    tree = ast.parse(path.read_text(), filename=str(path))
    own = _own_names(tree)
    found = []
    for node in ast.walk(tree):
        target = name = None
        if isinstance(node, ast.Attribute) and _private(node.attr):
            target, name = node.value, node.attr
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ATTR_FUNCTIONS
              and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
              and isinstance(node.args[1].value, str) and _private(node.args[1].value)):
            target, name = node.args[0], node.args[1].value
        if target is None or _is_self(target) or name in own:
            continue
        found.append(f"{path}:{node.lineno}: {ast.unparse(node)}")
    return found


def _files():
    for root in (PACKAGE, TESTS):
        yield from (p for p in sorted(root.rglob("*.py")) if p not in ALLOWED_FILES and ".venv" not in p.parts)


def test_no_module_or_test_reaches_into_private_names():
    found = [line for path in _files() for line in private_reaches(path)]
    assert not found, ("use a public method/property, or a function of grasswidget/compat.py for another "
                       "package's private API:\n" + "\n".join(found))


def test_the_check_finds_what_it_should(tmp_path):
    """The walk flags a foreign private read, a getattr of one and a private call, and
    leaves self, super() and a file's own names alone."""
    sample = tmp_path / "sample.py"
    sample.write_text(
        "class A:\n"
        "    def __init__(self):\n"
        "        self._mine = 1\n"
        "        super()._setup()\n"
        "    def f(self, other, scene):\n"
        "        other._mine\n"
        "        scene._draw\n"
        "        getattr(scene, '_step_count', 0)\n"
        "        scene._make_renderer()\n"
        "        return self._mine, cls_helper._private_helper\n"
        "def _private_helper():\n"
        "    pass\n"
    )
    found = [line.split(": ", 1)[1] for line in private_reaches(sample)]
    assert sorted(found) == sorted(["scene._draw", "getattr(scene, '_step_count', 0)", "scene._make_renderer"])


def test_compat_holds_the_private_uses():
    found = private_reaches(PACKAGE / "compat.py")
    assert found, "compat.py is where upstream private API is used; the allow-list would be pointless"
