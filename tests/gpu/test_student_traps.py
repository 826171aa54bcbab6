"""The traps of a student's code on the GPU (lavapipe here): the instrumented function returns
what the plain one returns, and records the first operation that divided by zero, normalized a
zero vector or took the sqrt of a negative number, whatever the adapter made of its value."""

import numpy as np

from grasswidget.core.student_wgsl import TRAP_VAR, instrument
from grasswidget.gpu.function_probe import call_function

CODE = """\
fn ratio(a: f32, h: f32, v: vec3<f32>) -> vec3<f32> {
    let r = a / (h - 1.0);
    let n = normalize(v);
    return n * r + vec3<f32>(sqrt(a));
}
"""


def test_traps_name_the_operation_and_leave_the_values_alone():
    a = np.array([4.0, 4.0, 4.0, -4.0])
    h = np.array([3.0, 1.0, 3.0, 3.0])  # the second divides by zero
    v = np.array([[1.0, 0, 0], [1.0, 0, 0], [0, 0, 0], [0, 2.0, 0]])  # the third normalizes a zero vector
    args = (["f32", "f32", "vec3<f32>"], "vec3<f32>", [a, h, v])
    code, sites = instrument(CODE)
    assert [s.kind for s in sites] == ["division by zero", "normalize of a zero vector", "sqrt of a negative number"]
    out = call_function(code, "ratio", *args, read_after=(TRAP_VAR,))
    plain = call_function(CODE, "ratio", *args)
    assert out[TRAP_VAR].tolist() == [0, 1, 2, 3]  # the first trap of each call, 1-based; 0: none
    ok = out[TRAP_VAR] == 0
    np.testing.assert_allclose(out["r"][ok], plain["r"][ok], rtol=1e-6)
    np.testing.assert_allclose(out["r"][0], [2.0 + 2.0, 2.0, 2.0], rtol=1e-6)  # the reference: n * 2 + sqrt(4)
