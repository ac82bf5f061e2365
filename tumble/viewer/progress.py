"""Long runs with a progress bar: ``simulate(world, seconds)`` and the bar the exporter uses.

The bar is tqdm's when tqdm is installed (it comes with ``tumble[viewer]``); without it,
runs go silently. ``progress=None`` means: show a bar when the run is long enough to
want one and stderr is a terminal.
"""
import sys

import numpy as np

from ..errors import ModelError


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def progress_bar(total, desc, unit, progress):
    """A tqdm bar over ``total`` units, or a silent stand-in when ``progress`` is False (or
    None and stderr is not a terminal) or tqdm is missing."""
    if progress is None:
        progress = bool(getattr(sys.stderr, "isatty", lambda: False)())
    if not progress:
        return _NoBar()
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return _NoBar()
    return tqdm(total=total, desc=desc, unit=unit, leave=False, dynamic_ncols=True)


def simulate(world, seconds, *, fps=None, control=None, on_frame=None, progress=None,
             desc="simulating"):
    """Step ``world`` for ``seconds`` of simulated time.

    fps : call ``on_frame(world)`` every ``1 / fps`` s of simulated time (rounded to whole
        steps, at least one) and after the last step; None: once, at the end.
    control : ``control(world)`` is called before every step (a controller that sets
        forces, torques or motor targets); without it the steps between frames go in one
        compiled ``world.step(n)`` call.
    progress : show a progress bar (True, False, or None for "when it is long": more
        than 2000 steps and a terminal).
    Returns the number of steps taken. The number of steps is ``round(seconds / dt)``.
    """
    seconds = float(seconds)
    if not np.isfinite(seconds) or seconds < 0:
        raise ModelError(f"simulate: seconds must be a finite number >= 0, got {seconds!r}")
    total = int(round(seconds / world.dt))
    if fps is None:
        # 100 compiled calls keep a progress bar moving at no measurable cost
        chunk = max(1, total // 100) if control is None else 1
    else:
        if not fps > 0:
            raise ModelError(f"simulate: fps must be > 0, got {fps!r}")
        chunk = max(1, int(round(1.0 / (float(fps) * world.dt))))
    if progress is None and total < 2000:
        progress = False
    done = 0
    with progress_bar(total, desc, "step", progress) as bar:
        while done < total:
            n = min(max(chunk, 1), total - done)
            if control is None:
                world.step(n)
            else:
                for _ in range(n):
                    control(world)
                    world.step(1)
            done += n
            bar.update(n)
            if on_frame is not None and fps is not None:
                on_frame(world)
    if on_frame is not None and fps is None:
        on_frame(world)
    return done
