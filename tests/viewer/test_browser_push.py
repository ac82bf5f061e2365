"""Pushing a body with the mouse in a real headless Chromium: a drag on a body pulls it
through ``World.apply_force`` (its own module, so the replay page of test_browser.py is
closed and not rendering meanwhile)."""
import time

import numpy as np
import pytest

import tumble
from tests.viewer.helpers import Page, projected_bodies

pytest.importorskip("viser")
from tumble.viewer import Viewer  # noqa: E402


def test_dragging_a_body_pushes_it(browser):
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane", friction=0.5)
    box = b.add_body("box", pos=(0.0, 0.0, 0.2), density=300.0)
    b.add_geom(box, "box", size=(0.2, 0.2, 0.2), friction=0.5)
    world = tumble.World(b.build(), dt=1.0 / 240.0, contact="pgs")
    world.step(60)                                             # settle on the ground
    start = world.body_pos[0].copy()
    with Viewer(world, port=0, paused=True) as viewer:
        page = Page(browser, viewer.url)
        try:
            page.settle()
            page.page.get_by_role("button", name="Play").click()
            time.sleep(0.3)
            assert viewer.playing and world.time > 0.25
            # playing alone leaves the resting box where it is
            assert np.linalg.norm(world.body_pos[0] - start) < 5e-3
            cam = list(viewer.server.get_clients().values())[0].camera
            x, y = projected_bodies(viewer.scene, world.body_pos, world.body_quat, cam).mean(0)
            page.page.mouse.move(x, y)
            page.page.mouse.down()
            page.page.mouse.move(x - 60, y, steps=4)
            page.page.mouse.move(x - 250, y, steps=10)
            time.sleep(0.8)
            page.page.mouse.up()
            time.sleep(0.3)
            moved = np.linalg.norm(world.body_pos[0, :2] - start[:2])
            assert moved > 0.05, f"the box moved {moved:.3f} m"
            # towards the pointer: to the left on the screen
            x_after = projected_bodies(viewer.scene, world.body_pos, world.body_quat,
                                       cam).mean(0)[0]
            assert x_after < x - 20
            # viser's client calls preventDefault in a passive listener during a drag, which
            # Chromium reports as an error; anything else is ours
            intervention = "Unable to preventDefault inside passive event listener"
            assert [e for e in page.errors if intervention not in e] == []
        finally:
            page.close()
