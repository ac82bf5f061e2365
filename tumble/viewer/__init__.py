"""Seeing a simulation: recordings, the browser viewer, headless video export and plots.

* :class:`Recorder` / :class:`Recording` — collect poses (and optionally contacts,
  velocities, energy, joint coordinates) while stepping; exact ``.npz`` save and load.
  NumPy only: always available.
* :class:`Viewer` / :func:`view` — the interactive browser viewer (viser, three.js).
* :func:`export_video` — MP4, GIF or PNG without a display (software rendering).
* :mod:`tumble.viewer.plots` — matplotlib figures: energy, joint angle against target,
  contact forces.
* :func:`simulate` — step a world for a while with a progress bar.

The viewer, export and plots need the ``viewer`` extra (``pip install 'tumble[viewer]'``);
their names are imported on first use so ``import tumble`` stays light.
"""
from .progress import simulate
from .recorder import Recorder, Recording
from .scene import Scene

_LAZY = {"Viewer": "app", "view": "app", "export_video": "export", "Camera": "render",
         "Renderer": "render", "plots": None}

__all__ = ["Recorder", "Recording", "Scene", "simulate", *_LAZY]


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'tumble.viewer' has no attribute {name!r}")
    import importlib
    if _LAZY[name] is None:
        return importlib.import_module(f".{name}", __name__)
    return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
