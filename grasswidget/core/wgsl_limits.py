"""Cheap checks on WGSL a user wrote, made before anything compiles (pure Python).

Some WGSL takes a shader compiler down rather than failing with an error: an expression
nested thousands of parentheses deep or a sum of tens of thousands of terms overflows
the compiler's stack (a segmentation fault in ``create_shader_module``), a private array
of 16 million vectors makes the driver allocate without end, a 100,000-element constant
array loses the GPU device, helpers that each call the one before twice grow
exponentially when the driver inlines them. None of these is needed by any exercise or
wind, so :func:`wgsl_limit_problem` refuses them by their text, naming the user's line
and column, before the code reaches a compiler. What slips through is caught by the
isolated compile (:mod:`grasswidget.gpu.isolation`); these checks make the common cases
cheap and precise.

The limits (each a module constant, applied to the code with comments blanked):

- :data:`MAX_CODE_CHARS` characters in all (32,768);
- :data:`MAX_NESTING` levels of ``(``, ``[`` and ``{`` together (48);
- :data:`MAX_STATEMENT_TERMS` names and numbers in one statement (500);
- :data:`MAX_ARRAY_ELEMENTS` elements in one array type, nested arrays multiplied (256),
  an array of an ``alias`` or a ``struct`` counted by what the name holds, and in one
  ``struct`` or ``alias`` (its members added up); an array's size must be a number or a module
  ``const`` set to a number;
- :data:`MAX_TOTAL_ELEMENTS` array elements in the whole code (512), each array type and
  each mention of an ``alias`` or ``struct`` counted;
- :data:`MAX_INLINED_TERMS` names and numbers in one function with every call of the
  user's own functions written out, as a driver inlines them (20,000).

Used by :meth:`~grasswidget.core.wgsl_overrides.FunctionOverrides.check` (exercise
functions, function overrides) and for ``params.wind_wgsl`` by both engines.
"""

from __future__ import annotations

import functools
import re

__all__ = ["wgsl_limit_problem", "MAX_CODE_CHARS", "MAX_NESTING", "MAX_STATEMENT_TERMS", "MAX_ARRAY_ELEMENTS",
           "MAX_INLINED_TERMS", "MAX_TOTAL_ELEMENTS"]

#: Most characters of one piece of user WGSL (the exercises' solutions are under 1,500).
MAX_CODE_CHARS = 32_768
#: Most levels of brackets ``( [ {`` open at once (a compiler recursed 3,500 deep and crashed).
MAX_NESTING = 48
#: Most names and numbers in one statement (a sum of 50,000 terms crashed the compiler).
MAX_STATEMENT_TERMS = 500
#: Most elements of one array type (``array<vec4<f32>, 16777216>`` exhausted memory;
#: a 100,000-element ``const`` array lost the device; on lavapipe one array of 1,024 indexed by
#: a computed index made a grade run past 60 s, 512 took 18 s, 256 about 6 s).
MAX_ARRAY_ELEMENTS = 256
#: Most array elements of the whole code: every array type written out, and every mention of an
#: ``alias`` or ``struct`` holding arrays, added up (on lavapipe two arrays of 256 indexed by a
#: computed index made a grade take 21 s; 100 ``const`` arrays of 1,024 zeros each ran it past 60 s).
MAX_TOTAL_ELEMENTS = 512
#: Most names and numbers of one function once the user's own functions it calls are
#: written out in place (the drivers inline every call).
MAX_INLINED_TERMS = 20_000

_TERM = re.compile(r"[A-Za-z_]\w*|\d[\w.]*|\.\d[\w.]*")
_INT = re.compile(r"^(0[xX][0-9a-fA-F]+|\d+)[iu]?$")


def _line_col(code, offset):
    return code.count("\n", 0, offset) + 1, offset - (code.rfind("\n", 0, offset) + 1) + 1


def _problem(code, offset, message, reason):
    line, column = _line_col(code, offset)
    return message, line, column, reason


def _int_value(text, consts):
    text = text.strip()
    if _INT.match(text):
        digits = text.rstrip("iu")
        return int(digits, 16) if digits[:2] in ("0x", "0X") else int(digits)
    if text in consts:
        return consts[text]
    return None


def _array_problem(code, text):
    """The first array type of ``text`` with too many elements (or a size that is not a number)."""
    consts = {}
    for m in re.finditer(r"\b(?:const|override)\s+(\w+)\s*(?::\s*\w+\s*)?=\s*([^;]+);", text):
        value = _int_value(m.group(2), {})
        if value is not None:
            consts[m.group(1)] = value

    named = _named_type_elements(text)

    def parse(at):
        """(elements, end offset) of the array type whose ``<`` is at ``at``; raises _Refused."""
        depth, k, commas = 0, at, []
        while k < len(text):
            ch = text[k]
            if ch == "<":
                depth += 1
            elif ch == ">":
                depth -= 1
                if depth == 0:
                    break
            elif ch == "," and depth == 1:
                commas.append(k)
            elif ch in ";{}":
                break
            k += 1
        inner_start = at + 1
        if not commas:  # runtime-sized array<T>: only a storage binding may have one; the compiler decides
            return 1, k
        elem, count_text = text[inner_start:commas[-1]], text[commas[-1] + 1:k]
        count = _int_value(count_text, consts)
        if count is None:
            raise _Refused(at, "an array's size must be a number, or a `const` set to a number, up to "
                               f"{MAX_ARRAY_ELEMENTS}; got `{count_text.strip()}`", "array size not a number")
        per = 1
        inner = re.search(r"\barray\s*<", elem)
        if inner:
            per, _ = parse(inner_start + inner.end() - 1)
        elif elem.strip() in named:  # an alias or a struct: its own elements, each
            per = named[elem.strip()]
        return count * per, k

    for name, elements in named.items():  # a struct of many arrays is as large as one long array
        if elements > MAX_ARRAY_ELEMENTS:
            m = re.search(r"\b(?:struct|alias)\s+" + re.escape(name) + r"\b", text)
            return _problem(code, m.start(), f"`{name}` holds {elements:,} elements in all (at most "
                            f"{MAX_ARRAY_ELEMENTS:,}: large arrays make a GPU compile slow, huge ones can exhaust the "
                            "driver's memory or lose the device)", f"{name} of {elements} elements")
    total, inside = 0, -1
    declared = {m.start(2) for m in re.finditer(r"\b(struct|alias)\s+(\w+)", text)}
    mentions = (re.finditer(r"\barray\s*<", text), (m for m in re.finditer(r"\b[A-Za-z_]\w*\b", text)
                                                      if m.group() in named and m.start() not in declared))
    for m in sorted((m for ms in mentions for m in ms), key=lambda m: m.start()):
        if m.start() < inside:  # an array inside one already counted
            continue
        if m.group() in named:  # a variable, value or parameter of a named type
            elements = named[m.group()]
        else:
            try:
                elements, inside = parse(m.end() - 1)
            except _Refused as refused:
                return _problem(code, refused.offset, refused.message, refused.reason)
            if elements > MAX_ARRAY_ELEMENTS:
                return _problem(code, m.start(), f"an array of {elements:,} elements is too large (at most "
                                f"{MAX_ARRAY_ELEMENTS:,}: large arrays make a GPU compile slow, huge ones can exhaust "
                                "the driver's memory or lose the device)", f"array of {elements} elements")
        total += elements
        if total > MAX_TOTAL_ELEMENTS:
            return _problem(code, m.start(), f"the arrays up to here hold {total:,} elements in all (at most "
                            f"{MAX_TOTAL_ELEMENTS:,} in the whole code; many arrays can exhaust the GPU driver as one "
                            "huge one does)", f"arrays of {total} elements in all")
    return None


def _named_type_elements(text) -> dict:
    """name -> elements of each ``alias`` and ``struct`` of ``text`` (an array's size times its
    element's, a struct's members added up, anything else 1), so that an array of a named type
    counts what the name stands for. Sizes that are not numbers count 1 here (the array check
    refuses them)."""
    consts = {m.group(1): v for m in re.finditer(r"\bconst\s+(\w+)\s*(?::\s*\w+\s*)?=\s*([^;]+);", text)
              if (v := _int_value(m.group(2), {})) is not None}
    named = {}

    def elements(type_text, depth=0):
        type_text = type_text.strip()
        if depth > 64:
            return 1
        m = re.match(r"array\s*<(.*)>$", type_text, re.S)
        if m:
            inner = m.group(1)
            level, cut = 0, None
            for k, ch in enumerate(inner):
                level += ch == "<"
                level -= ch == ">"
                if ch == "," and level == 0:
                    cut = k
            if cut is None:
                return elements(inner, depth + 1)
            count = _int_value(inner[cut + 1:], consts) or 1
            return count * elements(inner[:cut], depth + 1)
        return named.get(type_text, 1)

    for m in re.finditer(r"\b(alias\s+(\w+)\s*=\s*([^;]+);|struct\s+(\w+)\s*\{([^}]*)\})", text):
        if m.group(2):
            named[m.group(2)] = elements(m.group(3))
        else:  # members `name: type,` with the types' commas inside < > kept together
            members, level, start = [], 0, 0
            body = m.group(5)
            for k, ch in enumerate(body + ","):
                level += ch == "<"
                level -= ch == ">"
                if ch == "," and level == 0:
                    members.append(body[start:k])
                    start = k + 1
            named[m.group(4)] = sum(elements(part.split(":", 1)[1]) for part in members if ":" in part)
    return named


class _Refused(Exception):
    def __init__(self, offset, message, reason):
        super().__init__(message)
        self.offset, self.message, self.reason = offset, message, reason


def _inlined_problem(code, text, funcs):
    """The first function whose size with the user's own callees written out is too large."""
    by_name = {f.name: f for f in funcs}
    own, calls = {}, {}
    for f in funcs:
        body = text[f.start:f.end]
        own[f.name] = len(_TERM.findall(body))
        calls[f.name] = [m.group(1) for m in re.finditer(r"\b(\w+)\s*\(", body)
                         if m.group(1) in by_name and m.group(1) != f.name]

    @functools.lru_cache(maxsize=None)
    def size(name, depth=0):
        if depth > len(funcs):  # a call circle (not WGSL; the compiler says so)
            return 0
        return own[name] + sum(size(c, depth + 1) for c in calls[name])

    over = [(size(f.name), f) for f in funcs if size(f.name) > MAX_INLINED_TERMS]
    if over:  # the smallest one too large: where the growth is
        total, f = min(over, key=lambda pair: pair[0])
        return _problem(code, f.start, f"`{f.name}` grows to {total:,} terms once the functions it calls are "
                            f"written out in place, as the GPU driver does (at most {MAX_INLINED_TERMS:,}); call "
                            "helpers fewer times, or keep a result in a `let`", f"{f.name} too large inlined")
    return None


def wgsl_limit_problem(code: str, text: str, functions) -> tuple:
    """The first limit ``code`` (user WGSL: exercise functions, function overrides or a
    ``wind_wgsl`` body) breaks, as ``(message, line, column, reason)`` with the line and
    column (1-based) in ``code``; None when it keeps every limit. ``text`` is ``code`` with
    its comments blanked and ``functions`` its module-scope functions (both from
    :mod:`grasswidget.core.wgsl_overrides`, which calls this: :func:`~grasswidget.core.
    wgsl_overrides.limit_problem`). See the module docstring for the limits. Pure; about
    linear in the length of the code."""
    if len(code) > MAX_CODE_CHARS:
        return (f"the code is {len(code):,} characters long; at most {MAX_CODE_CHARS:,} are accepted", None, None,
                "code too long")
    depth, terms, start = 0, 0, 0
    for m in re.finditer(r"[(\[{]|[)\]}]|;|[A-Za-z_]\w*|\d[\w.]*", text):
        tok = m.group()
        if tok in "([{":
            depth += 1
            if depth > MAX_NESTING:
                return _problem(code, m.start(), f"brackets nested more than {MAX_NESTING} deep (a compiler "
                                f"recurses once per level and can crash); split the expression with `let`",
                                "nested too deep")
            if tok == "{":
                terms = 0
        elif tok in ")]}":
            depth -= 1
            if tok == "}":
                terms = 0
        elif tok == ";":
            terms = 0
        else:
            if terms == 0:
                start = m.start()
            terms += 1
            if terms > MAX_STATEMENT_TERMS:
                return _problem(code, start, f"one statement with more than {MAX_STATEMENT_TERMS} names and "
                                "numbers (a compiler can crash on a huge expression); split it with `let`",
                                "statement too long")
    return _array_problem(code, text) or _inlined_problem(code, text, functions)
