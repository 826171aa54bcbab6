"""Blade-count changes from a comm subshell's thread while frames stream (the soak's crash).

JupyterLab 4.4+ sends widget comm messages to an ipykernel 7 subshell (setting
``commsOverSubshells``, "perCommTarget" by default): the blades slider's
``set_blades`` runs on the subshell's thread while the canvas draws on the
kernel's main event loop. Before the fix, the swap released the old field's GPU
buffers in the middle of a frame that still used them, and wgpu-native aborted the
process ("Buffer with '' label has been destroyed" in ``wgpuQueueSubmit``).

The sequence runs in a subprocess (an abort kills the process): the main thread's
event loop draws and sends frames the way jupyter-rfb asks for them; another
thread waits until a frame is being drawn and changes the blade count then, for
every change, and records that the frame was still in progress when it asked (so
the race is shown to happen, not hoped for). The process must exit 0, log no draw
error, and send a frame of grass after every change.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("jupyter_rfb")

ROOT = Path(__file__).resolve().parents[2]
#: Blade-count changes made mid-frame (before the fix the first one or two aborted).
SWAPS = 6
COUNTS = (2048, 3072)

SCRIPT = r"""
import asyncio, json, logging, sys, threading
import numpy as np
import pygfx, rendercanvas, wgpu  # noqa: F401  (their loggers exist before ours are attached)
import grasswidget as gw

SWAPS, COUNTS = int(sys.argv[1]), (int(sys.argv[2]), int(sys.argv[3]))
errors = []

class Record(logging.Handler):
    def emit(self, record):
        errors.append(record.getMessage()[:300])

for name in ("rendercanvas", "wgpu", "pygfx"):
    logging.getLogger(name).addHandler(Record(level=logging.ERROR))


async def main():
    w = gw.GrassWidget(blades=COUNTS[0], size=(160, 120))
    canvas = w.canvas
    canvas.handle_event({"event_type": "resize", "width": 160, "height": 120, "pixel_ratio": 1.0})
    w.ball.enabled = True
    w.ball.rolling = True
    w.playing = True
    sent = []
    sent_more = threading.Condition()  # notified at each frame sent
    wake = threading.Event()  # set at each frame sent, and when the subshell is done
    send = canvas.send_frame
    def counting_send(array):
        with sent_more:
            sent.append(np.asarray(array).copy())
            sent_more.notify_all()
        send(array)
        wake.set()
    canvas.send_frame = counting_send
    in_frame = threading.Event()
    get_frame = canvas.get_frame
    def watched_get_frame():  # what jupyter-rfb calls when the browser is ready for a frame
        in_frame.set()
        try:
            return get_frame()
        finally:
            in_frame.clear()
    canvas.get_frame = watched_get_frame
    done, swaps, thread_errors, mid_frame = threading.Event(), [], [], []

    def subshell():  # the comm subshell: the blades slider moves while a frame is drawn
        try:
            for k in range(SWAPS):
                count = COUNTS[(k + 1) % 2]
                before = len(sent)
                for _attempt in range(100):  # catch a frame in the middle of its step + render
                    in_frame.wait(60)
                    if in_frame.is_set():
                        break
                mid_frame.append(in_frame.is_set())  # the race this test is about: a swap during a frame
                w.set_blades(count)
                swaps.append(count)
                with sent_more:  # two frames of the new field reach the browser (at most a minute)
                    sent_more.wait_for(lambda: len(sent) >= before + 2, timeout=60)
        except BaseException as exc:
            thread_errors.append(repr(exc))
        finally:
            done.set()
            wake.set()

    worker = threading.Thread(target=subshell, name="comm-subshell")
    worker.start()
    while not done.is_set():
        wake.clear()
        canvas.get_frame()
        # the pixels arrive through the GPU download's promise, which this loop resolves meanwhile
        await asyncio.to_thread(wake.wait, 2.0)
    worker.join()
    count = len(sent)
    wake.clear()
    canvas.get_frame()
    await asyncio.to_thread(wake.wait, 60.0)
    assert len(sent) > count, "the last frame was never sent"
    last = sent[-1][..., :3].astype(np.int32)
    grass = (last[..., 1] > last[..., 0] + 8) & (last[..., 1] > last[..., 2] + 8)
    print("RESULT " + json.dumps({
        "frames": len(sent), "swaps": swaps, "blade_count": w.blade_count, "errors": errors,
        "thread_errors": thread_errors, "mid_frame": mid_frame, "grass_fraction": float(grass.mean()),
        "last_shape": list(sent[-1].shape)}), flush=True)
    w.close()

asyncio.run(main())
"""


@pytest.mark.slow
def test_blade_count_changes_from_a_comm_thread_while_frames_stream():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(SWAPS), *map(str, COUNTS)], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=600)
    tail = (proc.stdout + proc.stderr)[-3000:]
    assert proc.returncode == 0, f"the process died (exit {proc.returncode}):\n{tail}"
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    assert lines, f"no result:\n{tail}"
    result = json.loads(lines[-1][len("RESULT "):])
    assert result["thread_errors"] == [] and result["errors"] == [], result
    assert result["swaps"] == [COUNTS[(k + 1) % 2] for k in range(SWAPS)]
    assert result["blade_count"] == result["swaps"][-1]
    # Each change was asked for while a frame was being drawn (the race happened, every time).
    assert result["mid_frame"] == [True] * SWAPS, result["mid_frame"]
    assert result["frames"] >= 2 * SWAPS + 1  # two frames of each new field, and one more
    assert result["last_shape"][:2] == [120, 160] and result["last_shape"][2] == 4
    assert result["grass_fraction"] > 0.2, result  # a drawn meadow, not a blank frame
