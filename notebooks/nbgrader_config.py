# nbgrader's configuration for a course made of the grass exercises (docs/teaching.md, "Grading a
# class with nbgrader"). Copy it into the course folder, next to source/.
c = get_config()  # noqa: F821 (nbgrader provides get_config)

# What replaces the teacher's answer in a student copy. The answer region follows the starter WGSL
# (the `code = """..."""` string the student edits), so the copy keeps the starter and says where to
# work, instead of nbgrader's default `raise NotImplementedError()`, which would stop Run All there.
c.ClearSolutions.code_stub = {"python": "# Your functions go in the WGSL above: edit it, then run this cell."}

# A grade compiles the student's WGSL and runs the GPU passes: seconds per cell on a CPU adapter
# (lavapipe), more with a cold shader cache. nbgrader's default is 30 s per cell.
c.Execute.timeout = 300
