"""Keep Numba's on-disk cache consistent with the package sources.

Numba keys a cached kernel on the file that defines it, not on the files of the kernels
it inlines, so editing ``integrate.py`` would leave ``step.py``'s cached step running
the old code. On import we fingerprint every source file of the package that uses Numba
and drop all cached kernels when the fingerprint changed (an upgrade or an edit); editing
a pure-Python file (a loader, the viewer) keeps the compiled kernels.
"""
import hashlib
import os
from pathlib import Path

_STAMP = "tumble-sources.stamp"


def _fingerprint(root):
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        if b"numba" not in path.read_bytes():
            continue
        st = path.stat()
        h.update(f"{path.relative_to(root)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def invalidate_stale_kernels(root=Path(__file__).parent):
    """Delete cached kernels (``*.nbi``, ``*.nbc``) if any source changed since they were made."""
    try:
        cache = root / "__pycache__"
        stamp = cache / _STAMP
        current = _fingerprint(root)
        if stamp.exists() and stamp.read_text() == current:
            return False
        for pattern in ("*.nbi", "*.nbc"):
            for f in root.rglob(pattern):
                f.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        tmp = cache / f"{_STAMP}.{os.getpid()}"
        tmp.write_text(current)
        os.replace(tmp, stamp)
        return True
    except OSError:
        # A read-only install: Numba then caches elsewhere or not at all; nothing to clean.
        return False
