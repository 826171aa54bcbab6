"""What the exercise grader checks and watches in a student's WGSL, beyond the overriding (pure Python).

Two jobs, both on the student's own text (:class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`'s
``code``), both naming the student's line and column:

- :func:`check_names`: characters and names a student's functions may not use, refused
  before anything compiles with :class:`~grasswidget.errors.ExerciseShaderError`: a NUL or
  another control character (the compiler reads the text as a C string and would stop
  there, so the error would be about code the student never wrote); the engine's own
  bindings (``u_sim``, ``s_blades``, ... every ``u_``/``s_`` global the shipped shaders
  use: the functions get their inputs as arguments, and a binding exists in one pass but
  not in another); entry points and bindings of their own (``@compute``, ``@group``, ...);
  and the names the grader's probe reserves (``probe_in``, ``probe_out``, ``probe_main``,
  anything starting with ``gwtrap_``).
- :func:`instrument`: the code rewritten so that each operation that can make an infinity
  or a NaN records where it first did so in a ``var<private> gwtrap_site: u32`` (0: none):
  the divisor of every ``/`` and ``/=`` (zero: division by zero), the argument of
  ``normalize`` (a zero vector), ``sqrt``/``log``/``log2`` (negative; ``log`` also zero),
  ``inverseSqrt`` (zero or negative) and ``acos``/``asin`` (outside -1..1). WGSL lets an
  adapter assume that no infinity or NaN happens (lavapipe turns ``x / 0.0`` into 0), so
  the result alone cannot show them on every adapter; the trap can. The grader's probe
  (:mod:`grasswidget.gpu.function_probe`) reads ``gwtrap_site`` after each call;
  :class:`TrapSite` says what and where. The rewriting only wraps operands in
  ``select(x, x, gwtrap_hit(k, test))``, which returns ``x`` unchanged.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from ..errors import ExerciseShaderError
from .wgsl_overrides import strip_comments

__all__ = ["TrapSite", "check_names", "engine_globals", "instrument", "TRAP_VAR", "RESERVED_NAMES"]

#: The private variable the instrumented code records its first trap in (1-based site, 0: none).
TRAP_VAR = "gwtrap_site"

#: Names of the grader's probe harness (gpu/function_probe.py); a student's code may not declare them.
RESERVED_NAMES = ("probe_in", "probe_out", "probe_main")

#: Code longer than this (characters) or with more slashes than MAX_TRAP_SITES is not instrumented:
#: an exercise's functions are a few hundred characters with a handful of divisions.
MAX_INSTRUMENTED_CHARS = 20000
MAX_TRAP_SITES = 100

_ATTRIBUTES = ("compute", "vertex", "fragment", "group", "binding", "workgroup_size")

#: Characters allowed in WGSL source below U+0020: tab, line feed, vertical tab, form feed, carriage return.
_BLANK_CONTROLS = "\t\n\x0b\x0c\r"


def _line_col(code, offset):
    line = code.count("\n", 0, offset) + 1
    return line, offset - (code.rfind("\n", 0, offset) + 1) + 1


def _error(code, label, message, offset, reason):
    line, column = _line_col(code, offset)
    src = code.split("\n")[line - 1]
    shown = "".join(c if c >= " " or c == "\t" else f"\\x{ord(c):02x}" for c in src)
    text = f"{label} line {line}, column {column}: {message}\n  {line} | {shown}"
    return ExerciseShaderError(text, line, column, reason, "")


@functools.lru_cache(maxsize=1)
def engine_globals() -> tuple:
    """The names of the engine's bindings the shipped shaders use (``u_sim``, ``s_blades``,
    ...: every ``u_``/``s_`` name that is not a local ``let``/``var``/parameter), sorted."""
    from .shader_files import read_shader, shader_names

    names, local = set(), set()
    for name in shader_names():
        text = strip_comments(read_shader(name))
        names.update(re.findall(r"\b([us]_\w+)\b", text))
        local.update(re.findall(r"\b(?:let|var)\s+([us]_\w+)\b", text))
        local.update(re.findall(r"[(,]\s*([us]_\w+)\s*:", text))
    return tuple(sorted(names - local))


def check_names(code: str, label: str = "your code") -> None:
    """Raise :class:`~grasswidget.errors.ExerciseShaderError` (the student's line and column)
    when ``code`` holds a control character other than blank space (a NUL included), uses
    one of the engine's bindings (:func:`engine_globals`), declares an entry point or a
    binding (``@compute``, ``@vertex``, ``@fragment``, ``@group``, ``@binding``,
    ``@workgroup_size``) or uses a name the grader reserves (:data:`RESERVED_NAMES`,
    ``gwtrap_...``). ``label`` starts the message ("your forces code")."""
    for m in re.finditer(r"[\x00-\x1f\x7f]", code):
        if m.group() not in _BLANK_CONTROLS:
            what = "a NUL character (\\x00)" if m.group() == "\x00" else f"the control character \\x{ord(m.group()):02x}"
            raise _error(code, label, f"{what} is not allowed in WGSL source; delete it (it is invisible in most "
                                      "editors: retype the line)", m.start(), "control character")
    text = strip_comments(code)
    bound = set(engine_globals())
    for m in re.finditer(r"[A-Za-z_]\w*", text):
        word = m.group()
        if m.start() > 0 and text[m.start() - 1] == "@" and word in _ATTRIBUTES:
            raise _error(code, label, f"`@{word}` is not allowed: your functions are called by the engine's passes; "
                                      "write plain functions without entry points or bindings", m.start() - 1,
                         f"@{word} not allowed")
        if m.start() > 0 and (text[m.start() - 1].isalnum() or text[m.start() - 1] in "_."):
            continue
        if word in bound:
            raise _error(code, label, f"`{word}` is the engine's own binding and is not available to your functions: "
                                      "use the function's parameters (everything it needs is passed in)", m.start(),
                         f"engine binding {word}")
        if word in RESERVED_NAMES or word.startswith("gwtrap_"):
            raise _error(code, label, f"the name `{word}` is reserved by the grader; rename it", m.start(),
                         f"reserved name {word}")


# ------------------------------------------------------------------ the traps


@dataclass(frozen=True)
class TrapSite:
    """One watched operation of the student's code: ``index`` (1-based, what ``gwtrap_site``
    holds when it fired first), ``kind`` ("division by zero", "normalize of a zero vector",
    ...), ``line``/``column`` (1-based, in the student's code, of the operation), ``text`` (that line as
    written, comments left out, shortened to 80 characters)."""

    index: int
    kind: str
    line: int
    column: int
    text: str

    def describe(self) -> str:
        """``division by zero at your line 21, column 31: `let fr = dot(v2 - v0, up) / 0.0;```."""
        return f"{self.kind} at your line {self.line}, column {self.column}: `{self.text}`"


#: function -> (what goes wrong, the test of its argument x that traps)
_CALL_TRAPS = {
    "normalize": ("normalize of a zero vector", "all(({x}) == ({x}) - ({x}))"),
    "sqrt": ("sqrt of a negative number", "any(({x}) < ({x}) - ({x}))"),
    "inverseSqrt": ("inverseSqrt of zero or a negative number", "any(({x}) <= ({x}) - ({x}))"),
    "log": ("log of zero or a negative number", "any(({x}) <= ({x}) - ({x}))"),
    "log2": ("log2 of zero or a negative number", "any(({x}) <= ({x}) - ({x}))"),
    "acos": ("acos outside -1..1", "any(abs({x}) > ({x}) - ({x}) + 1.0)"),
    "asin": ("asin outside -1..1", "any(abs({x}) > ({x}) - ({x}) + 1.0)"),
}

_NUMBER = re.compile(r"(0[xX][0-9a-fA-F.]+([pP][+-]?\d+)?[fhiu]?|(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?[fhiu]?)")
_IDENT = re.compile(r"[A-Za-z_]\w*")
_OPEN = {"(": ")", "[": "]"}


def _skip_blank(text, i):
    while i < len(text) and text[i].isspace():
        i += 1
    return i


def _match_close(text, i):
    """Index one past the bracket closing the one at ``i``; -1 when unbalanced."""
    close, depth = _OPEN[text[i]], 0
    for j in range(i, len(text)):
        c = text[j]
        if c in "([":
            depth += 1
        elif c in ")]":
            depth -= 1
            if depth == 0:
                return j + 1 if c == close else -1
    return -1


def _template_end(text, i):
    """Index one past a template list ``<...>`` at ``i`` (``vec3<f32>``); -1 when none."""
    if i >= len(text) or text[i] != "<":
        return -1
    depth = 0
    for j in range(i, min(len(text), i + 80)):
        if text[j] == "<":
            depth += 1
        elif text[j] == ">":
            depth -= 1
            if depth == 0:
                return j + 1
        elif not (text[j].isalnum() or text[j] in "_, "):
            return -1
    return -1


def _unary_end(text, i):
    """(start, end, is_literal) of the unary expression starting at or after ``i`` (WGSL's
    right operand of ``/``: prefix operators, then a primary with its postfixes); None when
    it cannot be read."""
    i = _skip_blank(text, i)
    start = i
    while i < len(text) and text[i] in "-!~":
        i = _skip_blank(text, i + 1)
    if i >= len(text):
        return None
    literal = False
    if text[i] == "(":
        i = _match_close(text, i)
        if i < 0:
            return None
    elif text[i].isdigit() or (text[i] == "." and i + 1 < len(text) and text[i + 1].isdigit()):
        m = _NUMBER.match(text, i)
        i, literal = m.end(), True
    else:
        m = _IDENT.match(text, i)
        if not m:
            return None
        i = m.end()
        t = _template_end(text, _skip_blank(text, i))
        if t > 0:
            i = t
        j = _skip_blank(text, i)
        if j < len(text) and text[j] == "(":
            i = _match_close(text, j)
            if i < 0:
                return None
    while True:  # postfixes: .member, [index]
        j = _skip_blank(text, i)
        if j < len(text) and text[j] == "." and j + 1 < len(text) and (text[j + 1].isalpha() or text[j + 1] == "_"):
            i = _IDENT.match(text, j + 1).end()
        elif j < len(text) and text[j] == "[":
            i = _match_close(text, j)
            if i < 0:
                return None
        else:
            return start, i, literal


def _is_zero_literal(s):
    s = s.strip().rstrip("fhiu")
    try:
        return float(s) == 0.0
    except ValueError:
        return False


def _short(s):
    s = " ".join(s.split())
    return s if len(s) <= 80 else s[:77] + "..."


def _trap(index, x, test):
    return f"select({x}, {x}, gwtrap_hit({index}u, {test}))"


def instrument(code: str):
    """``code`` with its divisions and the arguments of ``normalize``, ``sqrt``,
    ``inverseSqrt``, ``log``, ``log2``, ``acos`` and ``asin`` trapped (see the module
    docstring), and the declarations the traps need appended. Returns (instrumented code,
    list of :class:`TrapSite`); (code, []) when there is nothing to trap, the code is longer
    than :data:`MAX_INSTRUMENTED_CHARS` or has more than :data:`MAX_TRAP_SITES` slashes, or the
    rewritten text would be more than four times as long. A divisor that is a
    literal zero traps on every call; a nonzero literal is not watched."""
    if len(code) > MAX_INSTRUMENTED_CHARS or len(re.findall(r"/", code)) > MAX_TRAP_SITES:
        return code, []  # far beyond any exercise: graded without traps (the scan below is quadratic at worst)
    text = strip_comments(code)
    edits, sites = [], []  # (start, end, replacement)

    lines = text.split("\n")

    def add(kind, start, end, at):
        line, column = _line_col(code, at)
        sites.append(TrapSite(len(sites) + 1, kind, line, column, _short(lines[line - 1])))
        return len(sites)

    for m in re.finditer(r"/=?", text):
        if m.group() == "/=":
            end = text.find(";", m.end())
            if end < 0:
                continue
            x = text[m.end():end].strip()
            k = add("division by zero", m.end(), end, m.start())
            edits.append((m.end(), end, " " + _trap(k, f"({x})", f"any(({x}) == ({x}) - ({x}))")))
            continue
        got = _unary_end(text, m.end())
        if got is None:
            continue
        start, end, literal = got
        x = text[start:end]
        if literal and not _is_zero_literal(x):
            continue
        k = add("division by zero", start, end, m.start())
        test = f"any(({x}) == ({x}) - ({x}))"
        rep = f"(({x}) + select(0.0, 0.0, gwtrap_hit({k}u, true)))" if literal else _trap(k, x, test)
        edits.append((start, end, rep))
    for m in re.finditer(r"\b(" + "|".join(_CALL_TRAPS) + r")\s*\(", text):
        if m.start() > 0 and (text[m.start() - 1] in "._" or text[m.start() - 1].isalnum()):
            continue
        close = _match_close(text, m.end() - 1)
        if close < 0:
            continue
        x = text[m.end():close - 1].strip()
        if not x:
            continue
        if len(sites) >= MAX_TRAP_SITES:
            break
        kind, test = _CALL_TRAPS[m.group(1)]
        k = add(kind, m.end(), close, m.start())
        edits.append((m.end(), close - 1, _trap(k, f"({x})", test.format(x=x))))
    if not sites:
        return code, []
    edits.sort()
    kept, at = [], 0
    for start, end, rep in edits:  # nested sites: keep the outer edit, its text holds the inner one as written
        if start < at:
            continue
        kept.append((start, end, rep))
        at = end
    out, at = [], 0
    for start, end, rep in kept:
        out.append(text[at:start])
        out.append(rep)
        at = end
    out.append(text[at:])
    out.append(f"\nvar<private> {TRAP_VAR}: u32;\nfn gwtrap_hit(site: u32, hit: bool) -> bool {{\n"
               f"    if (hit && {TRAP_VAR} == 0u) {{ {TRAP_VAR} = site; }}\n    return hit;\n}}\n")
    result = "".join(out)
    if len(result) > 4 * len(code) + 4000:
        return code, []
    return result, sites
