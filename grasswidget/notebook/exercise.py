"""``gw.exercise(name)``: the CIS 565 grass assignment in a notebook.

An :class:`Exercise` shows its task (what to compute, the paper's equations, the
functions' signatures and units), gives the ``starter`` code and the teacher's
``solution()``, grades a student's WGSL in the real passes (:meth:`Exercise.grade`,
:mod:`grasswidget.tools.grading`) and runs it live (:meth:`Exercise.widget`,
:meth:`Exercise.compare`). The definitions are :mod:`grasswidget.core.exercises`.
"""

from __future__ import annotations

import numpy as np

from ..core.exercises import EXERCISES, PASS_FILES, VARIANTS, exercise_variant, pass_source, reference_examples
from ..core.grade_report import format_value
from ..core.shader_files import render_wgsl
from ..core.wgsl_overrides import parse_functions
from ..errors import GrassTypeError, GrassValueError

__all__ = ["Exercise", "exercise", "EXERCISES", "VARIANTS", "ReferenceExamples"]


class Exercise:
    """One exercise of the assignment (see :func:`exercise`).

    Attributes: ``name``, ``variant`` ("equations" or "derive"), ``title``, ``functions``
    (the names to write), ``starter`` (WGSL with the functions to fill in, marked TODO; it
    never passes), ``task`` (Markdown), ``pass_file`` (the shader that calls the functions)
    and ``spec`` (the :class:`~grasswidget.core.exercises.ExerciseSpec`).
    """

    def __init__(self, name: str, variant: str = "equations"):
        self.spec = exercise_variant(name, variant)
        self.variant = self.spec.variant
        self._graded = None  # (code, report) of the last grade: nbgrader's test cells grade the same code again
        self.name = self.spec.name
        self.title = self.spec.title
        self.functions = self.spec.names
        self.starter = self.spec.starter
        self.pass_file = PASS_FILES[self.spec.kind]

    def __repr__(self):
        variant = "" if self.variant == "equations" else f" ({self.variant})"
        return f"<Exercise {self.name!r}{variant}: {', '.join(self.functions)}>"

    # ------------------------------------------------------------------ the task

    def signatures(self) -> list:
        """The WGSL signatures to keep, ``fn name(...) -> type``, in the task's order."""
        stock = {f.name: f for f in parse_functions(render_wgsl("blade_math.wgsl"))}
        return [stock[n].signature for n in self.functions]

    @property
    def task(self) -> str:
        """The task as Markdown: what to compute, equations, signatures, units, how it is graded."""
        cell = (lambda text: text.replace("|", "\\|"))  # |x| in an equation is not a column
        rows = "\n".join(f"| `{f.name}` | {cell(f.label)} | {cell(f.equation)} | {f.units} |" for f in self.spec.functions)
        sigs = "\n".join(self.signatures())
        third = "what it does" if self.variant == "derive" else "equation"
        return (f"## {self.title}\n{self.spec.task}\n\n| function | computes | {third} | units |\n|---|---|---|---|\n"
                f"{rows}\n\nSignatures (keep them exactly; helper functions of your own are fine, loops are not):\n\n"
                f"```wgsl\n{sigs}\n```\n\nThe pass that calls them: `ex.pass_source` ({self.pass_file}). "
                f"Start from `ex.starter`, check with `ex.grade(code)`, watch with `ex.widget(code)`.")

    def _repr_markdown_(self):
        return self.task

    def __str__(self):
        return self.task

    @property
    def pass_source(self) -> str:
        """The WGSL around the functions: the call paths from the pass's entry point
        (``main`` of ``simulate.wgsl`` or ``cull.wgsl``) to each function to write, then the
        source of every function on those paths (e.g. ``tip_step`` of ``blade_math.wgsl``,
        which calls ``wind_force`` and ``integrate_tip``), each headed by its file
        (:func:`grasswidget.core.exercises.pass_source`)."""
        return pass_source(self.spec)

    def solution(self) -> str:
        """The teacher's answer (WGSL). Its first line says so: SOLUTION (teacher's answer). The
        same for both variants. The nbgrader source notebooks use it inside their solution
        region, which ``nbgrader generate_assignment`` removes; no cell of a student copy calls
        it (docs/teaching.md: what a student can still reach)."""
        return self.spec.solution

    def examples(self, function: str, count: int = 6) -> "ReferenceExamples":
        """What the reference returns for ``function`` (one of :attr:`functions`) on ``count``
        (1 to 64, default 6) inputs taken from the grading cases: a
        :class:`ReferenceExamples` table (Markdown in a notebook; ``.rows`` holds dicts
        ``case``, ``blade``, ``inputs``, ``reference``). The "derive" variant's evidence:
        the behaviour to match, without the formula."""
        if not isinstance(function, str):
            raise GrassTypeError(f"function must be a str, one of {', '.join(self.functions)}; "
                                 f"got {type(function).__name__}")
        if function not in self.functions:
            raise GrassValueError(f"function must be one of {', '.join(self.functions)}; got {function!r}")
        return ReferenceExamples(function, reference_examples(self.spec, function, count))

    # ------------------------------------------------------------------ grading and running

    def overrides(self, wgsl: str):
        """The student's ``wgsl`` as checked
        :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides` of this exercise's functions."""
        from ..tools.grading import overrides_for

        return overrides_for(self.spec, wgsl)

    def grade(self, wgsl: str):
        """Grade ``wgsl`` in the real passes against the NumPy reference: a
        :class:`~grasswidget.core.grade_report.GradeReport` (``.passed``; per function the
        verdict, the largest error, the failing cases and the worst blade). Raises
        :class:`~grasswidget.errors.ExerciseShaderError` (the student's line and column) for
        code that does not compile, misses a function, changes a signature or loops."""
        from ..tools.grading import grade

        if not isinstance(wgsl, str):
            raise GrassTypeError(f"wgsl must be a str of WGSL code; got {type(wgsl).__name__}")
        if self._graded is not None and self._graded[0] == wgsl:
            return self._graded[1]  # the same code, graded already (the cases and the grader are fixed)
        report = grade(self.spec, wgsl)
        self._graded = (wgsl, report)
        return report

    def _widget_params(self):
        from ..core.params import GrassParams

        if self.spec.kind == "culling":  # culled blades drawn in their test's colour; the three tests only
            return GrassParams(color_by="cull", cull_occlusion=False)
        return GrassParams(wind_strength=12.0)

    def widget(self, wgsl: str, blades: int = 2048, size=(480, 360), backend: str = "kernel", **kwargs):
        """A GrassWidget whose simulation and culling run ``wgsl``'s functions, live. The
        culling exercise starts with ``color_by = "cull"`` (culled blades flat in the colour
        of their test) and occlusion culling off. ``backend``: "kernel" (default; the
        functions can be changed later with ``w.set_function_overrides``), "browser" or
        "auto" (the browser compiles them when the widget starts). The code is checked
        (signatures, no loops) and, where the kernel has a GPU adapter, compiled first, so
        an error names the student's line before any widget shows. ``blades``, ``size`` and
        ``kwargs`` go to :class:`~grasswidget.GrassWidget`."""
        from ..tools.grading import check_compiles
        from .widget import GrassWidget

        overrides = self.overrides(wgsl)
        if backend != "kernel":
            check_compiles(overrides)
        kwargs.setdefault("params", self._widget_params())
        return GrassWidget(blades=blades, size=size, backend=backend, function_overrides=overrides, **kwargs)

    def compare(self, wgsl: str, blades: int = 1024, size=(320, 240), backend: str = "kernel"):
        """The student's functions and the reference side by side, "yours" and "reference".

        Kernel engine (default): a :func:`gw.compare <grasswidget.notebook.compare.compare>`
        comparison: one camera, one clock (``c.step(n)`` advances both exactly n steps), one
        panel on the shared parameters; ``c.widgets["yours"]`` runs the student's functions.
        ``backend="browser"`` or ``"auto"``: the browser compiles user functions only when a
        view starts, which a comparison's views cannot be given, so the two GrassWidgets stand
        in a :class:`~grasswidget.notebook.compare.SideBySide` (an HBox) instead, sharing one
        GrassParams (no linked camera or clock; marimo shows it too); ``.widgets``
        holds them too. The code is checked first (ExerciseShaderError with the line)."""
        from .compare import compare
        from .widget import GrassWidget

        overrides = self.overrides(wgsl)
        params = self._widget_params()
        if backend == "kernel":
            from ..tools.grading import check_compiles

            check_compiles(overrides)  # the error before any view exists
            comparison = compare({"yours": {}, "reference": {}}, blades=blades, size=size, params=params,
                                 backend="kernel")
            try:
                comparison.widgets["yours"].set_function_overrides(overrides)
            except BaseException:
                comparison.close()
                raise
            return comparison

        mine = self.widget(wgsl, blades=blades, size=size, params=params, backend=backend)
        try:
            ref = GrassWidget(blades=blades, size=size, params=params, backend=backend)
        except BaseException:
            mine.close()
            raise
        from .compare import SideBySide

        return SideBySide({"yours": mine, "reference": ref})


class ReferenceExamples:
    """A table of what the reference function ``function`` returns: ``rows`` (dicts ``case``,
    ``blade``, ``inputs``, ``reference``), shown as Markdown in a notebook and as text by ``str``."""

    def __init__(self, function: str, rows: list):
        self.function = function
        self.rows = rows

    def __len__(self):
        return len(self.rows)

    def _cells(self, row):
        args = ", ".join(f"{k}={format_value(v) if not isinstance(v, (bool, int)) else v}"
                         for k, v in row["inputs"].items())
        value = row["reference"]
        if isinstance(value, dict):
            shown = ", ".join(f"{k}={format_value(v)}" for k, v in value.items())
        elif isinstance(value, (bool, np.bool_)):
            shown = "true (cull)" if value else "false (keep)"
        else:
            shown = format_value(value)
        return f"{row['case']} #{row['blade']}", args, shown

    def __str__(self):
        lines = [f"reference {self.function} on blades of the grading cases:"]
        for row in self.rows:
            where, args, shown = self._cells(row)
            lines.append(f"  {where}: {self.function}({args}) = {shown}")
        return "\n".join(lines)

    def __repr__(self):
        return f"<ReferenceExamples {self.function}: {len(self.rows)} rows>"

    def _repr_markdown_(self):
        return self.to_markdown()

    def to_markdown(self) -> str:
        """The table as Markdown: one row per example (where, the inputs, the reference's value)."""
        esc = (lambda text: text.replace("|", "\\|"))
        rows = [f"| blade | inputs | reference `{self.function}` |", "|---|---|---|"]
        rows += ["| " + " | ".join(esc(c) for c in self._cells(row)) + " |" for row in self.rows]
        return "\n".join(rows)


def exercise(name: str, variant: str = "equations") -> Exercise:
    """The exercise ``name`` of the CIS 565 grass assignment: one of ``gw.EXERCISES``
    ("forces": gravity, front gravity, wind, recovery; "validation": ground, v1, length;
    "culling": orientation, frustum, distance). ``variant``: "equations" (default: the task
    gives the paper's equations) or "derive" (the physics in words and the reference's
    behaviour, :meth:`Exercise.examples`; the formulas are the student's to find; the same
    grader). Display it for the task; see :class:`Exercise`."""
    if not isinstance(name, str):
        raise GrassTypeError(f"name must be a str, one of {', '.join(EXERCISES)}; got {type(name).__name__}")
    return Exercise(name, variant)
