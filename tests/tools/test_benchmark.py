"""The benchmark's compute_raster_max_px sweep (``grasswidget bench --raster-max-px``)."""

import pytest

from grasswidget.errors import GrassValueError
from grasswidget.tools.benchmark import format_table, run_benchmark


def test_raster_max_px_sweep_rows():
    # the square meadow (horizon=False): at 96 x 54 its blades span 1..6 px across; to the horizon nearly
    # every blade is under a pixel there (each far blade's width grows with its distance), so both sweeps
    # would take the same blades
    report = run_benchmark("meadow", [4096], frames=1, size=(96, 54), progress=False, compute_raster="both",
                       raster_max_px=[1, 6], horizon=False)
    assert report["horizon"] is False
    rows = report["results"]
    assert [(r["compute_raster"], r["compute_raster_max_px"]) for r in rows] == [(False, None), (True, 1.0),
                                                                                 (True, 6.0)]
    off, narrow, wide = rows
    assert off["rastered"] == 0
    # a wider threshold sends more of the (same) visible blades to the compute rasterizer
    assert 0 < narrow["rastered"] < wide["rastered"] <= wide["visible"]
    table = format_table(report)
    assert " 6 " in table.splitlines()[-1]


def test_raster_max_px_out_of_range_names_the_parameter():
    with pytest.raises(GrassValueError, match="compute_raster_max_px"):
        run_benchmark("meadow", [64], frames=1, size=(32, 24), progress=False, raster_max_px=[40])


def test_compute_raster_on_from_the_first_frame():
    """The bench's GPU timer binds the field's buffers in compute programs of its own before the
    first frame; the compute rasterizer's first frame sizes its buffers then. Its counters' buffer
    is zeroed in place, not replaced (a replaced one was destroyed while still bound there, and
    the next submit aborted the process: 'Buffer has been destroyed')."""
    report = run_benchmark("meadow", [2048], frames=2, size=(96, 54), progress=False, compute_raster="on",
                       occlusion="off", horizon=False)
    (row,) = report["results"]
    assert row["compute_raster"] is True and 0 < row["rastered"] <= row["visible"]
