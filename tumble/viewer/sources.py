"""What ``tumble view MODEL`` and ``tumble export MODEL`` accept, turned into a World or a
Recording.

MODEL may be

* a recording, ``*.npz`` (written by ``Recorder.save``): replayed;
* a trained policy, ``*.npz`` (written by ``tumble train``; told from a recording by its
  ``meta`` entry, see ``tumble.rl.play.is_policy_file``): one character on the policy's
  clip, run by the policy (:class:`tumble.rl.play.PolicyDriver` is the controller; it
  starts the character over about 1 s after a fall);
* a Python file, ``*.py``: it is run (with ``__name__`` set to ``"__tumble_view__"``, so
  code under ``if __name__ == "__main__":`` is skipped), and the first of these it defines
  is used: ``world`` (a World), ``model`` (a Model), or a function ``build()`` /
  ``make_world()`` returning either. A function ``control(world)`` it defines is used as
  the controller (called before every step);
* an MJCF file, ``*.xml``, when this tumble has ``tumble.load_mjcf``;
* the name of a built-in demo (``tumble.apps.scenes.DEMOS``: ragdoll, stack, chain, racket),
  or else of a policy shipped in ``tumble/rl/policies`` (e.g. ``walk``).
"""
import os
import runpy

from ..errors import ModelError


def load_source(spec):
    """``(world or recording, control or None)`` for a MODEL argument (see the module notes).
    ModelError names the file and what is missing."""
    import tumble
    from ..apps import scenes
    from .recorder import Recording

    spec = os.fspath(spec)
    ext = os.path.splitext(spec)[1].lower()
    if ext == ".npz":
        from ..rl.play import is_policy_file
        if is_policy_file(spec):
            return _policy_source(spec)
        return Recording.load(spec), None
    if ext == ".py":
        if not os.path.isfile(spec):
            raise ModelError(f"model file '{spec}': no such file")
        namespace = runpy.run_path(spec, run_name="__tumble_view__")
        control = namespace.get("control")
        if control is not None and not callable(control):
            raise ModelError(f"model file '{spec}': 'control' must be a function control(world)")
        for name in ("world", "model", "build", "make_world"):
            if name not in namespace:
                continue
            value = namespace[name]
            if name in ("build", "make_world"):
                if not callable(value):
                    continue
                value = value()
            if isinstance(value, tumble.Model):
                value = tumble.World(value)
            if isinstance(value, tumble.World):
                return value, control
            raise ModelError(f"model file '{spec}': '{name}' is a {type(value).__name__}, "
                             f"not a tumble World or Model")
        raise ModelError(f"model file '{spec}' defines none of 'world', 'model', 'build()' "
                         f"or 'make_world()'")
    if ext == ".xml":
        loader = getattr(tumble, "load_mjcf", None)
        if loader is None:
            raise ModelError(f"'{spec}': this tumble cannot read MJCF files (no "
                             f"tumble.load_mjcf); give a .py model file, a .npz recording "
                             f"or a demo name")
        if not os.path.isfile(spec):
            raise ModelError(f"MJCF file '{spec}': no such file")
        return tumble.World(loader(spec)), None
    if spec in scenes.DEMOS:
        return scenes.build(spec), None
    if os.path.exists(spec):
        raise ModelError(f"'{spec}': expected a .py model file, a .npz recording or policy"
                         + (" or an MJCF .xml file" if hasattr(tumble, "load_mjcf") else ""))
    from ..rl.play import shipped_policies
    shipped = shipped_policies()
    if spec in shipped:
        return _policy_source(shipped[spec])
    raise ModelError(f"'{spec}' is neither a file nor a demo; the demos are "
                     f"{sorted(scenes.DEMOS)}"
                     + (f", the shipped policies {sorted(shipped)}" if shipped else ""))


def _policy_source(path):
    """(world, driver) of a policy file: one character, started at a random clip phase."""
    from ..rl.play import policy_world
    world, driver, _ = policy_world(os.fspath(path))
    return world, driver
