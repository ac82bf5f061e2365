"""Open the browser viewer on a live simulation: the stack demo, with contact points shown.

    python examples/live_viewer.py            # then open http://127.0.0.1:8080

Drag a box with the left mouse button to pull it; Pause, Step, scrub back with the Frame
slider and press Play to resume from there. Ctrl-C stops. Needs tumble[viewer].
The same from the command line: ``tumble view stack --contacts``.
"""
from tumble.apps import scenes
from tumble.viewer import view

world = scenes.stack()
view(world, contacts=True, forces=True, follow=None)     # serves until Ctrl-C
