"""The suite's fixtures: one meaning per name, and what a long-lived fixture makes on the GPU it frees.

An ast walk over tests/ (no test runs):

* a fixture defined in a test module (or a deeper conftest.py) may not take the name of a fixture
  of a conftest.py above it or beside it: a local ``scene`` that is not conftest's ``scene`` makes a
  reader of one file wrong about the other;
* a fixture of module, class, package or session scope that builds GPU objects (a GrassScene,
  GrassField, GrassWidget, comparison or device buffer) releases them itself (``yield``, then
  ``.release()`` / ``.close()`` / ``.destroy()``), instead of leaving them to the garbage
  collector for the rest of the run.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

TESTS = Path(__file__).parent

#: Calls that make GPU objects (buffers on the project's device) that live until released.
GPU_MAKERS = {"GrassScene", "GrassField", "GrassWidget", "Comparison", "compare", "preset", "create_buffer",
              "create_buffer_with_data"}
#: Calls that free them.
RELEASES = {"release", "close", "destroy"}


def _decorator_fixture(node):
    """(name, scope) when ``node`` is a pytest fixture, else None."""
    for dec in node.decorator_list:
        call = dec if isinstance(dec, ast.Call) else None
        target = call.func if call else dec
        if not ast.unparse(target).endswith("fixture"):
            continue
        name, scope = node.name, "function"
        for kw in call.keywords if call else ():
            if kw.arg == "name" and isinstance(kw.value, ast.Constant):
                name = kw.value.value
            if kw.arg == "scope" and isinstance(kw.value, ast.Constant):
                scope = kw.value.value
        return name, scope
    return None


@functools.lru_cache(maxsize=None)
def fixtures_in(source: str) -> tuple:
    """(name, scope, function node) of every fixture defined at any depth of ``source``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            fixture = _decorator_fixture(node)
            if fixture:
                found.append((*fixture, node))
    return tuple(found)


def _called(node) -> set:
    names = set()
    for call in ast.walk(node):
        if isinstance(call, ast.Call):
            f = call.func
            names.add(f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", ""))
    return names


def unreleased_gpu_fixtures(source: str) -> list:
    """Names of the long-lived fixtures in ``source`` that make GPU objects and free none."""
    out = []
    for name, scope, node in fixtures_in(source):
        called = _called(node)
        if scope != "function" and called & GPU_MAKERS and not called & RELEASES:
            out.append(name)
    return out


def _python_files():
    return [p for p in sorted(TESTS.rglob("*.py")) if ".venv" not in p.parts]


def _conftest_fixtures() -> dict:
    """conftest.py's folder -> names of the fixtures it defines."""
    return {p.parent: {name for name, _, _ in fixtures_in(p.read_text())}
            for p in _python_files() if p.name == "conftest.py"}


def shadowing(path: Path, source: str, conftests: dict) -> list:
    """'file:line: name' for each fixture of ``path`` that a conftest.py above (or beside) it also defines."""
    found = []
    for name, _, node in fixtures_in(source):
        for folder, names in conftests.items():
            if folder / "conftest.py" == path or name not in names:
                continue
            if path.parent == folder or folder in path.parents:
                found.append(f"{path.relative_to(TESTS)}:{node.lineno}: {name} (also in "
                             f"{(folder / 'conftest.py').relative_to(TESTS)})")
    return found


def test_no_fixture_takes_the_name_of_a_conftest_fixture_it_can_see():
    conftests = _conftest_fixtures()
    assert conftests.get(TESTS), "tests/conftest.py defines no fixture: the walk is broken"
    found = [line for p in _python_files() for line in shadowing(p, p.read_text(), conftests)]
    assert not found, "give the local fixture its own name:\n" + "\n".join(found)


def test_the_check_sees_a_shadowing_fixture():
    conftests = _conftest_fixtures()
    source = "import pytest\n\n@pytest.fixture(scope='module')\ndef scene():\n    return 1\n"
    assert shadowing(TESTS / "gpu" / "test_made_up.py", source, conftests) == [
        "gpu/test_made_up.py:4: scene (also in conftest.py)"]
    assert shadowing(TESTS / "gpu" / "test_made_up.py", source.replace("scene", "own_scene"), conftests) == []


def test_long_lived_fixtures_release_what_they_make_on_the_gpu():
    found = [f"{p.relative_to(TESTS)}: {name}" for p in _python_files()
             for name in unreleased_gpu_fixtures(p.read_text())]
    assert not found, "yield the object, then .release()/.close() it:\n" + "\n".join(found)


def test_the_check_sees_a_fixture_that_keeps_its_scene():
    kept = "import pytest, grasswidget as gw\n\n@pytest.fixture(scope='module')\ndef s():\n    return gw.GrassScene(64)\n"
    freed = ("import pytest, grasswidget as gw\n\n@pytest.fixture(scope='session')\ndef s():\n"
             "    s = gw.GrassScene.preset('meadow')\n    yield s\n    s.release()\n")
    per_test = kept.replace("(scope='module')", "")
    assert unreleased_gpu_fixtures(kept) == ["s"]
    assert unreleased_gpu_fixtures(freed) == [] and unreleased_gpu_fixtures(per_test) == []
