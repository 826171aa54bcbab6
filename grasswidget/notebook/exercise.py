"""``gw.exercise(name)``: the CIS 565 grass assignment in a notebook.

An :class:`Exercise` shows its task (what to compute, the paper's equations, the
functions' signatures and units), gives the ``starter`` code and the teacher's
``solution()``, grades a student's WGSL in the real passes (:meth:`Exercise.grade`,
:mod:`grasswidget.tools.grading`) and runs it live (:meth:`Exercise.widget`,
:meth:`Exercise.compare`). The definitions are :mod:`grasswidget.core.exercises`.
"""

from __future__ import annotations

from ..core.exercises import EXERCISES, PASS_FILES, exercise_spec, pass_source
from ..core.shader_files import render_wgsl
from ..core.wgsl_overrides import parse_functions
from ..errors import GrassTypeError

__all__ = ["Exercise", "exercise", "EXERCISES"]


class Exercise:
    """One exercise of the assignment (see :func:`exercise`).

    Attributes: ``name``, ``title``, ``functions`` (the names to write), ``starter``
    (WGSL with the functions to fill in, marked TODO; it never passes), ``task``
    (Markdown), ``pass_file`` (the shader that calls the functions) and ``spec`` (the
    :class:`~grasswidget.core.exercises.ExerciseSpec`).
    """

    def __init__(self, name: str):
        self.spec = exercise_spec(name)
        self.name = self.spec.name
        self.title = self.spec.title
        self.functions = self.spec.names
        self.starter = self.spec.starter
        self.pass_file = PASS_FILES[self.spec.kind]

    def __repr__(self):
        return f"<Exercise {self.name!r}: {', '.join(self.functions)}>"

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
        return (f"## {self.title}\n{self.spec.task}\n\n| function | computes | equation | units |\n|---|---|---|---|\n"
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
        """The teacher's answer (WGSL). Its first line says so: SOLUTION (teacher's answer)."""
        return self.spec.solution

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

        return grade(self.spec, wgsl)

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
        panel on the shared parameters; ``c.views["yours"]`` runs the student's functions.
        ``backend="browser"`` or ``"auto"``: the browser compiles user functions only when a
        view starts, which a comparison's views cannot be given, so the two GrassWidgets stand
        in an HBox instead, sharing one GrassParams (no linked camera or clock); ``.views``
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
                comparison.views["yours"].set_function_overrides(overrides)
            except BaseException:
                comparison.close()
                raise
            return comparison

        import ipywidgets as ipw

        mine = self.widget(wgsl, blades=blades, size=size, params=params, backend=backend)
        try:
            ref = GrassWidget(blades=blades, size=size, params=params, backend=backend)
        except BaseException:
            mine.close()
            raise
        views = {"yours": mine, "reference": ref}
        box = ipw.HBox([ipw.VBox([ipw.HTML(f"<b>{title}</b>"), w]) for title, w in views.items()])
        box.views = views
        return box


def exercise(name: str) -> Exercise:
    """The exercise ``name`` of the CIS 565 grass assignment: one of ``gw.EXERCISES``
    ("forces": gravity, front gravity, wind, recovery; "validation": ground, v1, length;
    "culling": orientation, frustum, distance). Display it for the task; see :class:`Exercise`."""
    if not isinstance(name, str):
        raise GrassTypeError(f"name must be a str, one of {', '.join(EXERCISES)}; got {type(name).__name__}")
    return Exercise(name)
