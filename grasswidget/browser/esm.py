"""The browser engine's one module text, assembled from its ES modules.

``engine.js`` (the anywidget entry) and the modules under ``js/`` are real ES modules:
relative ``import``/``export ... from`` lines tie them together, so node (and a browser)
can import each file directly, and the tests do. anywidget's ``_esm``, the live page
(:mod:`grasswidget.browser.page`) and the HTML export take one module text instead:
:func:`engine_module_text` puts every module into it once, dependencies first, with the
relative import lines taken out (each name is then declared once in the one text; the
check that names are unique is :func:`module_declarations`' job, run by the tests).
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

from ..errors import PageBuildError

__all__ = ["ENTRY", "engine_module_text", "assemble", "module_order", "module_declarations", "relative_imports",
           "resolve_import"]

HERE = Path(__file__).resolve().parent
#: The entry module (anywidget's ``export default {initialize, render}``), relative to this folder.
ENTRY = "engine.js"

#: One relative import or re-export on one line: ``import {a, b} from "./x.js";`` or
#: ``export {a} from "./x.js";`` (the only forms the engine's modules use).
_RELATIVE = re.compile(r'^(?:import|export)\s*\{[^}]*\}\s*from\s*"(\.{1,2}/[^"]+)";?\s*$', re.M)
#: A top-level declaration of a name (at the start of a line).
_DECLARATION = re.compile(r"^(?:export\s+)?(?:async\s+)?(?:const|let|var|function\*?|class)\s+([A-Za-z_$][\w$]*)", re.M)


def relative_imports(text: str) -> list:
    """The relative module paths ``text`` imports or re-exports from (in order)."""
    return _RELATIVE.findall(text)


def module_order(entry: str = ENTRY) -> list:
    """The engine's modules (paths relative to ``grasswidget/browser``, POSIX), each once,
    every module after the modules it imports; the entry last."""
    order, seen, visiting = [], set(), set()

    def visit(rel: str):
        if rel in seen:
            return
        if rel in visiting:
            raise PageBuildError(f"the browser engine's modules import each other in a circle at {rel}")
        visiting.add(rel)
        path = HERE / rel
        if not path.is_file():
            raise PageBuildError(f"the browser engine's module {rel} is missing from the package")
        for dep in relative_imports(path.read_text(encoding="utf-8")):
            visit(resolve_import(rel, dep))
        visiting.discard(rel)
        seen.add(rel)
        order.append(rel)

    visit(entry)
    return order


def resolve_import(module: str, dep: str) -> str:
    """The path (relative to ``grasswidget/browser``, POSIX) of what ``module`` imports as ``dep``
    (``"./x.js"``, ``"../x.js"``)."""
    parts = []
    for part in (Path(module).parent / dep).as_posix().split("/"):
        if part == "..":
            parts.pop()
        elif part not in (".", ""):
            parts.append(part)
    return "/".join(parts)


def module_declarations(text: str) -> list:
    """The names ``text`` declares at its top level (a line starting with const, let,
    function or class, exported or not), in order, repeats kept."""
    return _DECLARATION.findall(text)


def assemble(entry: str = ENTRY) -> str:
    """The module text of ``entry`` and every module it imports (see :func:`engine_module_text`);
    :class:`~grasswidget.errors.PageBuildError` when a module is missing, the modules import each
    other in a circle, or two declare one top-level name."""
    parts = []
    for rel in module_order(entry):
        text = (HERE / rel).read_text(encoding="utf-8")
        body = _RELATIVE.sub("", text).strip("\n")
        parts.append(f"// ==== grasswidget/browser/{rel}\n{body}\n")
    text = "\n".join(parts)
    names = module_declarations(text)
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise PageBuildError(f"the browser engine's modules declare {', '.join(repeated)} more than once; "
                                "one module text needs each top-level name once")
    return text


def engine_module_text() -> str:
    """The browser engine as one ES module text (what ``BrowserEngineWidget._esm``, the live page and the
    HTML export load): every module of :func:`module_order` once, dependencies first, relative
    imports taken out; the entry's ``export default`` and the rules' exports kept."""
    return _engine_module_text()


@functools.lru_cache(maxsize=1)
def _engine_module_text() -> str:
    return assemble(ENTRY)
