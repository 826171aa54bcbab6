"""The browser harness's modules import only the harness modules below them (tests/e2e/README.md,
"The harness's modules"), and each of its public names is defined once. No browser runs."""

from __future__ import annotations

import ast
from pathlib import Path

HERE = Path(__file__).parent

#: Each harness module and the harness modules it may import (at run time; names imported only
#: for type annotations, under ``if TYPE_CHECKING``, do not count).
LAYERS = {
    "polling": set(),
    "lab_page": set(),
    "servers": {"polling"},
    "chromium": {"polling"},
    "frames": {"polling"},
    "controls": {"polling"},
    "kernel_calls": {"polling", "lab_page"},
    "notebook_actions": {"polling", "lab_page", "kernel_calls", "frames", "servers"},
}


def _runtime_imports(tree) -> set:
    """The sibling modules (``from .x import``) a module imports outside ``if TYPE_CHECKING:``."""
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
            skipped.update(id(n) for n in ast.walk(node))
    return {node.module for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and node.level == 1 and id(node) not in skipped}


def harness_imports(source: str) -> set:
    return _runtime_imports(ast.parse(source))


def test_each_harness_module_imports_only_the_modules_below_it():
    wrong = {}
    for name, allowed in LAYERS.items():
        got = harness_imports((HERE / f"{name}.py").read_text())
        if got - allowed:
            wrong[name] = sorted(got - allowed)
    assert not wrong, f"harness modules importing above their layer: {wrong}"


def test_the_layer_check_can_fail():
    assert harness_imports("from .notebook_actions import open_notebook\nfrom .polling import poll\n") == {
        "notebook_actions", "polling"}
    assert harness_imports("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                           "    from .servers import JupyterLabServer\n") == set()


def test_every_public_name_has_one_home():
    homes = {}
    for name in LAYERS:
        tree = ast.parse((HERE / f"{name}.py").read_text())
        for node in tree.body:
            targets = []
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                targets = [node.name]
            elif isinstance(node, ast.Assign):
                targets = [t.id for t in node.targets if isinstance(t, ast.Name)]
            for target in targets:
                if not target.startswith("_"):
                    homes.setdefault(target, []).append(name)
    twice = {k: v for k, v in homes.items() if len(v) > 1}
    assert not twice, twice
    assert {"poll", "JupyterLabServer", "Browser", "kernel_eval", "open_notebook", "wait_for_frames",
            "set_slider"} <= set(homes)
