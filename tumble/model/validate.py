"""Checks shared by the builder and the loaders; each raises ModelError naming the field."""
import math
import numbers

import numpy as np

from ..errors import ModelError

# A quaternion further than this from unit length is refused rather than normalised.
QUAT_NORM_TOL = 1e-2


def vector(value, n, where, field, finite=True):
    """``value`` as a float array of shape (n,), finite unless ``finite`` is False (then
    only NaN is refused)."""
    try:
        a = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {field} must be {n} numbers, got {value!r}") from None
    if a.shape != (n,):
        raise ModelError(f"{where}: {field} must be {n} numbers, got {a.size}: {value!r}")
    if (not np.all(np.isfinite(a))) if finite else np.isnan(a).any():
        raise ModelError(f"{where}: {field} has non-finite entries: {a.tolist()}")
    return a


def unit_quat(value, where, field="quat"):
    """A finite (x, y, z, w) quaternion, normalised; zero or far-from-unit ones are refused."""
    q = vector(value, 4, where, field)
    norm = float(np.linalg.norm(q))
    if norm < 1e-12:
        raise ModelError(f"{where}: {field} is zero; give a unit quaternion (x, y, z, w)")
    if abs(norm - 1.0) > QUAT_NORM_TOL:
        raise ModelError(f"{where}: {field} has norm {norm:.6g}, not 1; give a unit quaternion "
                         f"(x, y, z, w), scalar last")
    return q / norm


def positive(value, where, field, allow_zero=False):
    """A finite float > 0 (or >= 0)."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise ModelError(f"{where}: {field} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < 0.0 or (v == 0.0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ModelError(f"{where}: {field} must be finite and {bound}, got {value!r}")
    return v


def unit_vector(value, where, field):
    """A finite non-zero 3-vector, normalised."""
    v = vector(value, 3, where, field)
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        raise ModelError(f"{where}: {field} is the zero vector")
    return v / n


def index_of(value, index, kind):
    """Index of a body/joint given by index or name; ``index`` maps names to indices.

    ``kind`` ('body', 'joint') names the thing in messages.
    """
    count = len(index)
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        if 0 <= value < count:
            return int(value)
        raise ModelError(f"{kind} index {value} out of range: there are {count} {kind}s")
    if isinstance(value, str):
        if value in index:
            return index[value]
        raise ModelError(f"unknown {kind} '{value}'; {kind}s are {list(index)}")
    raise ModelError(f"a {kind} is given by its index or name, got {value!r}")
