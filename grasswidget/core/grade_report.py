"""What the exercise grader found, for a student to act on (pure: text and HTML).

:class:`GradeReport` (one per ``ex.grade(wgsl)``) holds a :class:`FunctionGrade` per
function of the exercise: pass or fail, the largest error (blade heights for the
simulated functions, wrongly culled or kept blades for the culling tests), and the
worst failing blade (the largest error over all cases; for a culling test the wrongly
decided blade the reference decides most clearly): its case, the call of the function
that went wrong (the inputs the pass hands it, the reference value there (its NumPy
twin) and the student's), how far off v1 and v2 are, the blade's expected and actual
result, what decides a culling test (clip coordinates and the plane; d, the bucket and
the keep count), and, where the student's code divided by zero or the like, its line. It shows itself in a notebook (``_repr_html_``, ``_repr_markdown_``)
and as text (``str``).
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field

import numpy as np

from ..errors import GrassValueError

__all__ = ["FunctionGrade", "GradeReport", "format_value"]

#: The verdicts a function can get.
VERDICTS = ("pass", "fail", "NaN")


def format_value(x) -> str:
    """A short text for a value: vectors as (x, y, z) with 4 significant digits, matrices by rows."""
    if isinstance(x, dict):
        return ", ".join(f"{k} = {format_value(v)}" for k, v in x.items())
    if isinstance(x, (bool, np.bool_)):
        return "true (culled)" if x else "false (kept)"
    if isinstance(x, str):
        return x
    a = np.asarray(x)
    if a.dtype.kind in "iu":
        return str(a.tolist())
    if a.ndim == 0:
        return f"{float(a):.6g}"
    if a.ndim == 1:
        return "(" + ", ".join(f"{float(v):.5g}" for v in a) + ")"
    return "[" + "; ".join(format_value(row) for row in a) + "]"


@dataclass
class FunctionGrade:
    """The grade of one function.

    Attributes: ``name`` (the WGSL function), ``label`` (in words), ``verdict`` ("pass",
    "fail" or "NaN": the function made a NaN or infinity), ``max_error`` (the largest
    error: blade heights for simulated functions; for culling tests the number of
    blades culled or kept wrongly), ``error_unit``, ``checked`` (blades compared, over
    all cases), ``wrong`` (blades out of tolerance), ``tolerance`` and ``failure``
    (None, or a dict about the worst failing blade: ``case``, ``case_description``,
    ``blade``, ``inputs`` (dict of the function's arguments), ``reference`` (what the
    NumPy twin returns for them), ``your_value`` (what the student's function returned for
    them, None when not probed), ``expected`` and ``yours`` (the blade after the pass:
    dicts of v1/v2, or the culling verdict); optional: ``call`` (which of the function's
    calls for this blade, e.g. "collision pass 1 (...)"), ``call_index`` and ``calls``
    (0-based index and number of calls), ``errors`` ({"v1": e, "v2": e}, blade heights),
    ``trap`` (text: the operation of the student's code that divided by zero or the like
    first, with its line) and ``details`` (dict: what decides a culling test)).
    """

    name: str
    label: str
    verdict: str
    max_error: float
    error_unit: str
    checked: int
    wrong: int
    tolerance: float
    failure: dict | None = None
    failed_cases: tuple = ()

    @property
    def passed(self) -> bool:
        return self.verdict == "pass"

    def headline(self) -> str:
        """One line: the verdict and the largest error."""
        if self.error_unit == "blade heights":
            err = f"{self.max_error:.2e} blade heights" if np.isfinite(self.max_error) else "not a number"
            if self.verdict == "NaN":
                err = "NaN or infinity"
            size = f"largest error {err} (tolerance {self.tolerance:.0e})"
        else:
            size = f"{self.wrong} of {self.checked} blades culled or kept wrongly"
        word = {"pass": "PASS", "fail": "FAIL", "NaN": "FAIL (NaN or infinity)"}[self.verdict]
        return f"{word}  {self.name} ({self.label}): {size}"

    def failure_lines(self) -> list:
        """The worst failing blade, as lines of text ([] when the function passed)."""
        f = self.failure
        if not f:
            return []
        lines = []
        if self.failed_cases:
            lines.append("wrong in case" + ("s" if len(self.failed_cases) > 1 else "") + ": "
                         + ", ".join(f'"{c}"' for c in self.failed_cases))
        lines.append(f"worst blade: #{f['blade']} of case \"{f['case']}\" ({f['case_description']})")
        if f.get("calls", 1) > 1:
            lines.append(f"  the pass calls {self.name} {f['calls']} times for this blade; shown: call "
                         f"{f['call_index'] + 1}, {f['call']}")
        lines.append("  inputs: " + format_value(f["inputs"]))
        lines.append(f"  reference {self.name}(...) = {format_value(f['reference'])}")
        if f.get("your_value") is not None:
            lines.append(f"  your      {self.name}(...) = {format_value(f['your_value'])}")
        for key, value in (f.get("details") or {}).items():
            lines.append(f"  {key}: {format_value(value)}")
        lines.append(f"  expected after the pass: {format_value(f['expected'])}")
        lines.append(f"  yours:                   {format_value(f['yours'])}")
        if f.get("errors"):
            lines.append("  off by: " + ", ".join(
                f"{k} {v:.2e}" if np.isfinite(v) else f"{k} NaN or infinity" for k, v in f["errors"].items())
                + " blade heights")
        if f.get("trap"):
            lines.append(f"  your code: {f['trap']} (NaN or infinity; this adapter may show it as another number)")
        if self.verdict == "NaN" and not f.get("trap"):
            lines.append("  your function made NaN (not a number) or infinity: look for a division by zero, "
                         "normalize() of a zero vector or sqrt/log of a negative number")
        return lines


@dataclass
class GradeReport:
    """The result of grading an exercise: ``exercise``, ``title``, ``functions``
    (FunctionGrade, in the task's order), ``device`` (the adapter that ran the passes)
    and ``cases`` (the case names). ``passed`` is True when every function passed."""

    exercise: str
    title: str
    functions: list = field(default_factory=list)
    device: str = ""
    cases: tuple = ()

    @property
    def passed(self) -> bool:
        return bool(self.functions) and all(f.passed for f in self.functions)

    def __getitem__(self, name) -> FunctionGrade:
        for f in self.functions:
            if f.name == name:
                return f
        raise GrassValueError(f"name must be one of {', '.join(f.name for f in self.functions)}; got {name!r}")

    @property
    def failed(self) -> list:
        """Names of the functions that did not pass."""
        return [f.name for f in self.functions if not f.passed]

    def summary(self) -> str:
        n = sum(f.passed for f in self.functions)
        state = "all passed" if self.passed else f"{n} of {len(self.functions)} passed"
        names = ", ".join(f'"{c}"' for c in self.cases)  # quoted: a case name may hold a comma
        return f"exercise \"{self.exercise}\": {state} ({len(self.cases)} cases: {names}; {self.device})"

    def __str__(self):
        lines = [self.summary()]
        for f in self.functions:
            lines.append(f.headline())
            lines += ["    " + line for line in f.failure_lines()]
        return "\n".join(lines)

    def __repr__(self):
        return f"<GradeReport {self.exercise}: {'passed' if self.passed else 'failed ' + ', '.join(self.failed)}>"

    def _repr_markdown_(self):
        return self.to_markdown()

    def _repr_html_(self):
        return self.to_html()

    def to_markdown(self) -> str:
        """The report as Markdown: a table of the functions, then each failing one's worst blade."""
        rows = ["| function | result | largest error |", "|---|---|---|"]
        for f in self.functions:
            word = {"pass": "✅ pass", "fail": "❌ fail", "NaN": "❌ NaN or infinity"}[f.verdict]
            err = f.headline().split(": ", 1)[1]
            rows.append(f"| `{f.name}` ({f.label}) | {word} | {err} |")
        details = []
        for f in self.functions:
            if f.failure:
                details.append(f"**{f.name}**\n\n```\n" + "\n".join(f.failure_lines()) + "\n```")
        return f"**{html.escape(self.summary())}**\n\n" + "\n".join(rows) + "\n\n" + "\n\n".join(details)

    def to_html(self) -> str:
        """The report as HTML (what a notebook shows): the summary, a table of the functions
        (verdict in colour, the largest error, the worst failing blade)."""
        esc = html.escape
        colour = {"pass": "#1a7f37", "fail": "#cf222e", "NaN": "#cf222e"}
        rows = []
        for f in self.functions:
            word = {"pass": "pass", "fail": "fail", "NaN": "NaN or infinity"}[f.verdict]
            err = f.headline().split(": ", 1)[1]
            detail = ""
            if f.failure:
                detail = ("<pre style='margin:4px 0;white-space:pre-wrap;font-size:12px'>"
                          + esc("\n".join(f.failure_lines())) + "</pre>")
            rows.append(f"<tr><td><code>{esc(f.name)}</code><br><small>{esc(f.label)}</small></td>"
                        f"<td style='color:{colour[f.verdict]};font-weight:bold'>{word}</td>"
                        f"<td>{esc(err)}{detail}</td></tr>")
        head = colour["pass"] if self.passed else colour["fail"]
        return (f"<div class='grasswidget-grade'><p style='font-weight:bold;color:{head}'>{esc(self.summary())}</p>"
                "<table><thead><tr><th>function</th><th>result</th><th>details</th></tr></thead><tbody>"
                + "".join(rows) + "</tbody></table></div>")
