"""The viewer in a real headless Chromium: it loads without console errors, draws the bodies
where they are, and Play / Pause and the time slider change what is shown (a mouse drag:
test_browser_push.py)."""
import time

import numpy as np
import pytest

from tests.viewer.helpers import (Page, body_silhouettes, changed_pixels, dilate,
                                  synthetic_recording)

pytest.importorskip("viser")
from tumble.viewer import Viewer  # noqa: E402


# pixels that may change without the scene changing (the panel's status icon blinks)
NOISE = 100


def _camera(viewer):
    clients = list(viewer.server.get_clients().values())
    assert len(clients) == 1
    return clients[0].camera


@pytest.fixture(scope="module")
def replay(browser):
    rec = synthetic_recording()
    viewer = Viewer(rec, port=0, paused=True)
    page = Page(browser, viewer.url)
    page.settle()
    yield viewer, page, rec
    page.close()
    viewer.close()


def test_page_loads_without_console_errors(replay):
    viewer, page, _ = replay
    assert page.errors == []
    assert page.page.get_by_role("button", name="Play").is_visible()
    assert page.page.get_by_text("recording, 5 bodies").is_visible()


def test_bodies_are_drawn_where_they_are(replay):
    viewer, page, rec = replay
    viewer.seek(0)
    with_bodies = page.settle()
    page.page.get_by_label("Bodies", exact=True).click()      # hide them: an empty scene
    empty = page.settle()
    page.page.get_by_label("Bodies", exact=True).click()
    assert changed_pixels(page.settle(), with_bodies) <= NOISE   # and back

    changed = np.abs(with_bodies - empty).max(axis=-1) > 24
    # where the meshes project with the browser's own camera pose and field of view
    drawn = body_silhouettes(rec.scene, rec.body_pos[0], rec.body_quat[0], _camera(viewer))
    seen = np.ones_like(changed)
    seen[:, int(page.page.get_by_role("button", name="Play").bounding_box()["x"]) - 20:] = False
    seen[:160, :330] = False                                   # viser's notification card
    core, halo = dilate(drawn, -3) & seen, dilate(drawn, 3) & seen
    assert core.sum() > 5000
    # every pixel well inside a body changed, and nothing changed away from the bodies
    # (their faint shadows on the ground stay under the threshold)
    assert (changed & core).sum() >= 0.98 * core.sum()
    assert (changed & seen & ~halo).sum() <= 0.01 * (changed & seen).sum()
    assert page.errors == []


def test_play_and_pause_change_what_is_shown(replay):
    viewer, page, _ = replay
    viewer.seek(0)
    still = page.settle()
    time.sleep(0.5)
    assert changed_pixels(page.screenshot(), still) <= NOISE          # paused: nothing moves

    page.page.get_by_role("button", name="Play").click()
    # a software-rendered browser on a busy machine may take a while to draw the first
    # frames: wait (up to 20 s) for the picture to move rather than a fixed time
    deadline = time.monotonic() + 20.0
    while True:
        time.sleep(0.2)
        moving = page.screenshot()
        if (viewer.frame > 0 and changed_pixels(moving, still) > 500) \
                or time.monotonic() > deadline:
            break
    assert viewer.playing and viewer.frame > 0
    assert changed_pixels(moving, still) > 500

    page.page.get_by_role("button", name="Pause").click()
    stopped_at = viewer.frame
    paused = page.settle()
    time.sleep(0.5)
    assert not viewer.playing and viewer.frame == stopped_at
    assert changed_pixels(page.screenshot(), paused) <= NOISE
    assert page.errors == []


def _field(page, label):
    """The input next to a panel label (viser's labels do not point at their inputs)."""
    return page.page.locator(f"xpath=//label[text()='{label}']/ancestor::div"
                             f"[contains(@class, 'mantine-Flex-root')][1]//input")


def _scrub(page, fraction):
    """Drag the frame slider's thumb to ``fraction`` of its track with the mouse (the
    keyboard would also move the camera: viser binds the arrow keys)."""
    thumb = page.page.get_by_role("slider").first
    track = thumb.locator("xpath=ancestor::div[contains(@class, 'mantine-Slider-root')]")
    box, knob = track.bounding_box(), thumb.bounding_box()
    page.page.mouse.move(knob["x"] + knob["width"] / 2, knob["y"] + knob["height"] / 2)
    page.page.mouse.down()
    y = box["y"] + box["height"] / 2
    x = box["x"] + fraction * box["width"]
    page.page.mouse.move(x, y, steps=5)
    page.page.mouse.up()


def test_scrubbing_changes_what_is_shown(replay):
    viewer, page, rec = replay
    _scrub(page, 0.0)
    start = page.settle()
    assert viewer.frame == 0
    _scrub(page, 1.0)                                          # the play head to the end
    end = page.settle()
    assert viewer.frame == len(rec) - 1 and not viewer.playing
    assert changed_pixels(end, start) > 500
    assert _field(page, "Time").input_value() == f"{rec.time[-1]:.3f} s"
    _scrub(page, 0.5)
    middle = page.settle()
    assert abs(viewer.frame - (len(rec) - 1) / 2) <= 3
    assert changed_pixels(middle, end) > 500 and changed_pixels(middle, start) > 500
    viewer.seek(len(rec) - 1)                                  # the same frame from Python
    assert changed_pixels(page.settle(), end) <= NOISE
    assert page.errors == []


def test_the_camera_follows_the_centre_of_mass(replay):
    viewer, page, rec = replay
    viewer.seek(0)
    cam = _camera(viewer)
    offset = cam.position - cam.look_at
    page.page.get_by_role("combobox").last.click()             # the Follow dropdown
    page.page.get_by_role("option", name="centre of mass").click()
    deadline = time.monotonic() + 20          # the choice reaches the server asynchronously
    while viewer.follow != "com" and time.monotonic() < deadline:
        time.sleep(0.05)
    assert viewer.follow == "com"
    for i in (5, len(rec) - 1):
        viewer.seek(i)
        np.testing.assert_allclose(cam.look_at, rec.scene.com(rec.body_pos[i]), atol=1e-9)
        np.testing.assert_allclose(cam.position - cam.look_at, offset, atol=1e-9)
    page.settle()
    viewer.follow = None
    assert page.errors == []
