"""Replacing functions of the shipped WGSL with a user's own (pure Python).

The one mechanism by which user code takes the place of stock blade math (the
exercises of :mod:`grasswidget.core.exercises`): a :class:`FunctionOverrides`
holds the user's WGSL and the names of the ``blade_math.wgsl`` functions it
replaces. :meth:`FunctionOverrides.apply` takes a finished shader (rendered
template) that defines those functions, removes their stock definitions and
appends the user's code verbatim after one marker line, so that a compiler's
line ``L`` is the user's line ``L - marker_line``
(:meth:`FunctionOverrides.user_line`). WGSL declarations at module scope may come
in any order, so the appended functions are called where the stock ones were.

Checks made before anything compiles (:meth:`FunctionOverrides.check`), each an
:class:`~grasswidget.errors.ExerciseShaderError` naming the user's line and column:
every replaced function is defined once, with the stock parameter types and
return type; no loops (``for``, ``while``, ``loop``: none of the functions needs
one, and a shader that never ends can hang a CPU Vulkan driver and the kernel with
it; WGSL has no recursion, so code without loops always ends).

:meth:`FunctionOverrides.only` keeps one replaced function (and the user's helpers)
and blanks the others' lines, keeping line numbers: grading attributes an error to
one function by replacing it alone.
"""

from __future__ import annotations

import functools
import hashlib
import re
from dataclasses import dataclass

from ..errors import ExerciseShaderError, GrassTypeError, GrassValueError, WindShaderError
from .wgsl_limits import wgsl_limit_problem

__all__ = ["WgslFunction", "FunctionOverrides", "parse_functions", "strip_comments", "limit_problem", "wind_limit_error",
           "OVERRIDE_MARKER"]

#: Start of the marker line before the user's code in an overridden shader.
OVERRIDE_MARKER = "// ---- replaced blade math (user code; its line 1 is the next line):"

#: Keywords of WGSL loops, refused in user code (see the module docstring).
LOOP_KEYWORDS = ("for", "while", "loop")


@dataclass(frozen=True)
class WgslFunction:
    """One module-scope function of a WGSL text: ``name``; ``params`` (tuple of
    (name, type) with whitespace removed from types); ``returns`` (the return type,
    "" for none); ``start``/``end`` (character offsets of ``fn`` and one past the
    closing brace); ``line``/``column`` (1-based, of ``fn``); ``end_line``."""

    name: str
    params: tuple
    returns: str
    start: int
    end: int
    line: int
    column: int
    end_line: int

    @property
    def signature(self) -> str:
        """``fn name(a: T, ...) -> R`` in one line."""
        args = ", ".join(f"{n}: {t}" for n, t in self.params)
        return f"fn {self.name}({args})" + (f" -> {self.returns}" if self.returns else "")

    @property
    def types(self) -> tuple:
        """(parameter types, return type): what must match the stock function."""
        return tuple(t for _, t in self.params), self.returns


_COMMENT_TOKENS = re.compile(r"//|/\*|\*/")


def strip_comments(code: str) -> str:
    """``code`` with its comments (``//`` to the end of the line, ``/* */`` nested)
    replaced by spaces, newlines kept: offsets, lines and columns stay those of ``code``."""
    return _strip_comments(code)


@functools.lru_cache(maxsize=32)
def _strip_comments(code: str) -> str:
    spans, depth, start, pos = [], 0, 0, 0
    for m in _COMMENT_TOKENS.finditer(code):
        if m.start() < pos:
            continue
        tok = m.group()
        if depth == 0 and tok == "//":
            end = code.find("\n", m.start())
            end = len(code) if end < 0 else end
            spans.append((m.start(), end))
            pos = end
        elif tok == "/*":
            if depth == 0:
                start = m.start()
            depth += 1
        elif tok == "*/" and depth:
            depth -= 1
            if depth == 0:
                spans.append((start, m.end()))
    if depth:
        spans.append((start, len(code)))
    if not spans:
        return code
    out, at = [], 0
    for a, b in spans:
        out.append(code[at:a])
        out.append(re.sub(r"[^\n]", " ", code[a:b]))
        at = b
    out.append(code[at:])
    return "".join(out)


def limit_problem(code: str):
    """The first size limit user WGSL ``code`` breaks (length, nesting, statement length,
    array sizes, inlined size: :mod:`grasswidget.core.wgsl_limits`) as ``(message, line,
    column, reason)``, line and column 1-based in ``code`` (None for the length); None when
    it keeps them all. Checked before any compile of user code."""
    return wgsl_limit_problem(code, strip_comments(code), parse_functions(code))


def wind_limit_error(body: str):
    """A :class:`~grasswidget.errors.WindShaderError` for the first size limit a
    ``wind_wgsl`` body breaks (see :func:`limit_problem`), with the line and column in
    ``body``; None when it keeps them all (or is empty). Both engines check it first."""
    problem = limit_problem(body) if body.strip() else None
    if problem is None and body.strip():
        problem = _escape_problem(body)
    if problem is None:
        return None
    message, line, column, reason = problem
    rows = body.splitlines()
    where = f" line {line}, column {column}" if line else ""
    src = rows[line - 1] if line and line <= len(rows) else ""
    src = src if len(src) <= 160 else src[:157] + "..."
    return WindShaderError(f"wind_wgsl{where}: {message}" + (f"\n  {line} | {src}" if line else ""), line, column,
                           reason, "")


def _escape_problem(body: str):
    """``(message, line, column, reason)`` for the first ``}`` of a wind body that closes
    ``user_wind`` itself (what follows it would be module-scope code of the user's: bindings,
    entry points, large private arrays, none of them checked as a body); None when the
    body's braces stay inside the function."""
    depth = 0
    for m in re.finditer(r"[{}]", strip_comments(body)):
        depth += 1 if m.group() == "{" else -1
        if depth < 0:
            line, column = _line_col(body, m.start())
            return ("this `}` closes the function `user_wind` itself; wind_wgsl is the body of that one function "
                    "(statements ending in `return vec3<f32>(...)`), so every `{` and `}` in it must pair up",
                    line, column, "closes user_wind")
    return None


def _line_col(code: str, offset: int) -> tuple:
    line = code.count("\n", 0, offset) + 1
    return line, offset - (code.rfind("\n", 0, offset) + 1) + 1


_FN_HEAD = re.compile(r"\bfn\s+(\w+)\s*\(([^)]*)\)\s*(?:->\s*([^{]+?))?\s*\{")
_SCAN = re.compile(r"[{}]|\bfn\b")


def parse_functions(code: str) -> list:
    """The module-scope functions of WGSL ``code``, in order (a list of :class:`WgslFunction`).
    Comments are ignored; a function's extent is found by matching braces."""
    return list(_parse_functions(code))


@functools.lru_cache(maxsize=32)
def _parse_functions(code: str) -> tuple:
    text = strip_comments(code)
    found, depth, skip_to = [], 0, 0
    head = None
    for m in _SCAN.finditer(text):
        if m.start() < skip_to:
            continue
        tok = m.group()
        if tok == "{":
            depth += 1
        elif tok == "}":
            depth -= 1
            if head is not None and depth == 0:
                i, hm = head
                params = tuple(
                    (p.split(":")[0].strip(), re.sub(r"\s+", "", p.split(":", 1)[1]) if ":" in p else "")
                    for p in hm.group(2).split(",") if p.strip()
                )
                returns = re.sub(r"\s+", "", hm.group(3) or "")
                returns = re.sub(r"^@\w+(\([^)]*\))?", "", returns)
                line, column = _line_col(code, i)
                j = m.end()
                found.append(WgslFunction(hm.group(1), params, returns, i, j, line, column, _line_col(code, j - 1)[0]))
                head = None
        elif depth == 0:  # "fn" at module scope
            hm = _FN_HEAD.match(text, m.start())
            if hm:
                head = (m.start(), hm)
                depth = 1
                skip_to = hm.end()
    return tuple(found)


class FunctionOverrides:
    """User WGSL that replaces the stock definitions of some ``blade_math.wgsl`` functions.

    Args:
        code: the user's WGSL: the functions named in ``names`` (their stock
            signatures), and any helper functions or constants they need.
        names: the stock functions replaced (e.g. ``("wind_force",)``).
        label: how errors name the code (default "your code"), e.g. "the forces exercise".

    Hashable by content (:attr:`key`); immutable.
    """

    def __init__(self, code: str, names, label: str = "your code"):
        if not isinstance(code, str):
            raise GrassTypeError(f"code must be a str (WGSL); got {type(code).__name__}")
        names = tuple(names)
        if not names or not all(isinstance(n, str) and n.isidentifier() for n in names):
            raise GrassValueError(f"names must be a non-empty sequence of WGSL function names; got {names!r}")
        self.code = code
        self.names = names
        self.label = label
        self.key = hashlib.sha1((code + "\0" + ",".join(names)).encode()).hexdigest()[:16]

    def __repr__(self):
        return f"FunctionOverrides(names={self.names!r}, {len(self.code.splitlines())} lines, key={self.key})"

    def __eq__(self, other):
        return isinstance(other, FunctionOverrides) and other.key == self.key

    def __hash__(self):
        return hash(self.key)

    # ------------------------------------------------------------------ before compiling

    def _error(self, message, line=None, column=None, reason=""):
        where = f" line {line}" + (f", column {column}" if column else "") if line else ""
        text = f"{self.label}{where}: {message}"
        if line:
            src = self.code.splitlines()[line - 1] if line <= len(self.code.splitlines()) else ""
            src = src if len(src) <= 160 else src[:157] + "..."
            text += f"\n  {line} | {src}"
        return ExerciseShaderError(text, line, column, reason or message, "")

    def check(self, stock_code: str):
        """Raise :class:`~grasswidget.errors.ExerciseShaderError` unless the user's code
        keeps the size limits of :func:`limit_problem` (length, nesting, statement length,
        array sizes, inlined size), defines each replaced function exactly once with the
        parameter and return types of its definition in ``stock_code`` (e.g. the rendered
        ``blade_math.wgsl``), and has no loop. Returns self."""
        problem = limit_problem(self.code)
        if problem is not None:
            message, line, column, reason = problem
            raise self._error(message, line, column, reason)
        stock = {f.name: f for f in parse_functions(stock_code)}
        mine = parse_functions(self.code)
        text = strip_comments(self.code)
        for m in re.finditer(r"\b(" + "|".join(LOOP_KEYWORDS) + r")\b", text):
            line, col = _line_col(self.code, m.start())
            raise self._error(f"`{m.group(1)}` loops are not allowed here (a loop that never ends would hang the "
                              "GPU driver); none of these functions needs one: write the steps out", line, col,
                              "loop not allowed")
        for name in self.names:
            if name not in stock:
                raise GrassValueError(f"names: {name!r} is not a function of the stock WGSL")
            defs = [f for f in mine if f.name == name]
            if not defs:
                raise self._error(f"defines no function `{name}`; write `{stock[name].signature} {{ ... }}`",
                                  reason=f"missing {name}")
            if len(defs) > 1:
                raise self._error(f"defines `{name}` {len(defs)} times", defs[1].line, defs[1].column,
                                  f"{name} defined twice")
            f = defs[0]
            if f.types != stock[name].types:
                raise self._error(f"`{name}` must have the signature `{stock[name].signature}`; yours is "
                                  f"`{f.signature}`", f.line, f.column, f"wrong signature of {name}")
        return self

    # ------------------------------------------------------------------ composing

    def only(self, name: str) -> "FunctionOverrides":
        """The overrides of ``name`` alone: the other replaced functions' lines blanked
        (line numbers kept), the user's helpers and constants kept."""
        if name not in self.names:
            raise GrassValueError(f"name must be one of {', '.join(self.names)}; got {name!r}")
        lines = self.code.split("\n")
        for f in parse_functions(self.code):
            if f.name in self.names and f.name != name:
                for k in range(f.line - 1, f.end_line):
                    lines[k] = ""
        return FunctionOverrides("\n".join(lines), (name,), self.label)

    def applies_to(self, wgsl: str) -> bool:
        """Whether ``wgsl`` defines every replaced function (then :meth:`apply` changes it)."""
        defined = {f.name for f in parse_functions(wgsl)}
        return all(n in defined for n in self.names)

    def apply(self, wgsl: str) -> str:
        """``wgsl`` (a finished shader) with the stock definitions of the replaced
        functions removed and the user's code appended after the marker line; unchanged
        when it does not define them all (a shader without the blade math)."""
        funcs = [f for f in parse_functions(wgsl) if f.name in self.names]
        if {f.name for f in funcs} != set(self.names):
            return wgsl
        out, at = [], 0
        for f in funcs:
            out.append(wgsl[at:f.start])
            out.append(f"// {f.name}: replaced, see the end of this shader")
            at = f.end
        out.append(wgsl[at:])
        text = "".join(out)
        if not text.endswith("\n"):
            text += "\n"
        return f"{text}{OVERRIDE_MARKER} {', '.join(self.names)}\n{self.code}\n"

    def first_line(self, applied: str):
        """The line (1-based) of ``applied`` (a result of :meth:`apply`) holding the
        user's line 1; None when the code was not applied."""
        for k, line in enumerate(applied.split("\n")):
            if line.startswith(OVERRIDE_MARKER):
                return k + 2
        return None

    def user_line(self, applied: str, line: int):
        """The user's line for line ``line`` of ``applied``; None outside the user's code."""
        first = self.first_line(applied)
        n = len(self.code.split("\n"))
        if first is None or not (first <= line < first + n):
            return None
        return line - first + 1
