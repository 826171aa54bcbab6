import os
import tempfile

# The Vulkan loader complains on every start without a private runtime dir.
if not os.environ.get("XDG_RUNTIME_DIR"):
    d = os.path.join(tempfile.gettempdir(), f"xdg-{os.getuid()}")
    os.makedirs(d, mode=0o700, exist_ok=True)
    os.environ["XDG_RUNTIME_DIR"] = d

import numpy as np  # noqa: E402
import pytest  # noqa: E402


def grass_mask(img):
    """Pixels that are grass: green clearly dominates red and blue."""
    rgb = img[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return (g > r + 8) & (g > b + 8)


def sky_mask(img):
    """Pixels of the light-blue sky background."""
    rgb = img[..., :3].astype(np.int32)
    return (rgb[..., 2] > 180) & (rgb[..., 2] > rgb[..., 1]) & (rgb[..., 1] > rgb[..., 0])


@pytest.fixture(scope="session")
def small_blades():
    import grasswidget as gw

    return gw.Blades.on_plane(2048, seed=3)


#: View size of the test widgets (CSS pixels).
WIDGET_SIZE = (160, 120)




class TickingWall:
    """A simulated wall clock for GrassWidget's real-time clock: each reading is
    ``tick`` seconds after the one before (``advance(s)`` adds more)."""

    def __init__(self, tick=0.0):
        self.t = 1000.0
        self.tick = tick

    def __call__(self):
        self.t += self.tick
        return self.t

    def advance(self, seconds):
        self.t += seconds


@pytest.fixture
def widget():
    """A GrassWidget of 1024 blades at WIDGET_SIZE, closed after the test. Its
    simulation clock reads a TickingWall that moves one nominal frame interval
    (1 / max_fps) per reading, so each frame drawn while playing advances exactly
    ``steps_per_frame`` fixed steps (the clock reads the wall once per frame)."""
    import grasswidget as gw

    w = gw.GrassWidget(blades=1024, size=WIDGET_SIZE)
    w.view.clock.now = TickingWall(1.0 / w.max_fps)
    yield w
    w.close()
