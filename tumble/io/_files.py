"""Reading the files the loaders are given, with every way that can fail a tumble error.

A path may be missing, a directory, unreadable, hold a NUL byte or not be a path at
all, and a file may be far larger than any model or motion: :func:`read_file` turns each
into a ``ModelError`` naming the file (a missing file into :class:`MissingFileError`,
which is also the ``FileNotFoundError`` the loaders raised before), and reads at most the
cap it is given, so a huge file or a device that never ends cannot hang a load.
"""
import os

from ..errors import ModelError, StateError


#: Most bytes a state file (``World.load_state``) may unpack to.
MAX_STATE_BYTES = 2 ** 30


class MissingFileError(ModelError, FileNotFoundError):
    """A file that does not exist: a ``ModelError`` (so ``except tumble.TumbleError``
    catches it) that is also a ``FileNotFoundError``."""


class MissingStateFileError(StateError, FileNotFoundError):
    """A state file (``World.load_state``) that does not exist: a ``StateError`` that is
    also a ``FileNotFoundError``."""


def mib(n):
    """``n`` bytes as a short text for messages ('32 MiB')."""
    return f"{n / 2 ** 20:g} MiB" if n >= 2 ** 20 else f"{n} bytes"


def file_path(path, what):
    """``path`` (str, bytes or os.PathLike) as a str, refusing what ``open`` would refuse
    with an exception that is not an OSError (wrong type, NUL byte)."""
    try:
        p = os.fspath(path)
    except TypeError:
        raise ModelError(f"{what}: expected a file path, got {type(path).__name__}") from None
    if isinstance(p, bytes):
        p = os.fsdecode(p)
    if "\x00" in p:
        raise ModelError(f"{what}: the path {p!r} holds a NUL byte, which no file name can")
    return p


def read_file(path, what, max_bytes, *, cap_name=None, missing=MissingFileError):
    """The bytes of the file at ``path``; ``what`` (e.g. 'load_bvh') starts the messages.

    Raises ``missing`` (default :class:`MissingFileError`) when the file does not exist,
    and ModelError for a directory, an unreadable file, a bad path, or a file larger than
    ``max_bytes`` (``cap_name`` names the constant that sets it, for the message).
    """
    p = file_path(path, what)
    try:
        with open(p, "rb") as f:
            data = f.read(max_bytes + 1)
    except FileNotFoundError:
        raise missing(f"{what}: cannot read '{p}': no such file") from None
    except IsADirectoryError:
        raise ModelError(f"{what}: '{p}' is a directory, not a file") from None
    except OSError as e:
        raise ModelError(f"{what}: cannot read '{p}': {e.strerror or e}") from None
    except (ValueError, OverflowError) as e:
        raise ModelError(f"{what}: cannot read '{p}': {e}") from None
    if len(data) > max_bytes:
        cap = f" ({cap_name})" if cap_name else ""
        raise ModelError(f"{what}: '{p}' is larger than {mib(max_bytes)}, the most tumble "
                         f"reads{cap}")
    return data


def write_text(path, text, what):
    """Write ``text`` (UTF-8, '\\n' newlines) to ``path``; ModelError naming the file when it
    cannot be written (MissingFileError when its folder does not exist)."""
    p = file_path(path, what)
    try:
        with open(p, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
    except FileNotFoundError:
        raise MissingFileError(f"{what}: cannot write '{p}': no such folder") from None
    except IsADirectoryError:
        raise ModelError(f"{what}: '{p}' is a directory, not a file") from None
    except OSError as e:
        raise ModelError(f"{what}: cannot write '{p}': {e.strerror or e}") from None
