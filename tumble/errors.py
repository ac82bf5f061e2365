"""One error hierarchy for everything tumble refuses or detects.

``ModelError`` is bad input (a model, an option, a state written by the user);
``SimulationError`` is a simulation that diverged. Both derive from
``TumbleError`` so ``except tumble.TumbleError`` catches either.
"""


class TumbleError(Exception):
    """Base class of every error raised by tumble."""


class ModelError(TumbleError, ValueError):
    """Bad input: a model, option, name or state that tumble refuses.

    The message names the thing (body, geom, joint) and the field. Nothing has
    been changed when it is raised.
    """


class StateError(ModelError):
    """A state written by the user is invalid (non-finite, zero quaternion, bad shape)."""


class SimulationError(TumbleError, RuntimeError):
    """The simulation produced a non-finite or runaway state.

    Attributes ``body`` (name), ``step`` (index of the failing step within the
    call, 0-based), ``time`` (simulated time at the start of that step) and
    ``world`` (index in a batch) say where. The world is left as it was before
    the failing ``step(n)`` call.
    """

    def __init__(self, message, *, body=None, step=None, time=None, world=None):
        super().__init__(message)
        self.body = body
        self.step = step
        self.time = time
        self.world = world


class TumbleWarning(UserWarning):
    """Input that is legal but probably not what was meant (e.g. a joint anchor far away)."""
