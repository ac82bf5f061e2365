"""Keep Numba's on-disk cache consistent with the package sources.

Numba keys a cached kernel on the file that defines it, not on the files of the kernels
it inlines, so editing ``integrate.py`` would leave ``step.py``'s cached step running
the old code. On import we compare every Numba-using source file of the package with the
stamp recorded when its kernels were cached, and drop the cached kernels of each changed
file and of every file that imports one (directly or through others): their compiled
code may hold the changed functions. Editing a pure-Python file (a loader, the viewer)
keeps every compiled kernel; editing one pipeline stage recompiles that stage and the
step, not the collision routines.
"""
import json
import os
import re
from pathlib import Path

_STAMP = "tumble-sources.json"
# ``from .x.y import a, b`` / ``from .. import x`` (relative imports inside the package)
_IMPORT = re.compile(r"^[ \t]*from[ \t]+(\.+)([\w.]*)[ \t]+import[ \t]+(?:\(([^)]*)\)|([\w \t,]+))",
                     re.M)


def _numba_sources(root):
    """{path relative to root: source text} of the files that use Numba."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text or b"noalloc" in text:
            out[path.relative_to(root).as_posix()] = text.decode("utf-8", "replace")
    return out


def _module_file(root, package, dots, name):
    """The file a relative import names, relative to root, or None if not a source file."""
    base = package
    for _ in range(len(dots) - 1):
        base = base.parent
    target = base.joinpath(*name.split(".")) if name else base
    for cand in (target.with_suffix(".py"), target / "__init__.py"):
        if (root / cand).is_file():
            return cand.as_posix()
    return None


def import_graph(root, sources):
    """{file: set of package files it imports} over ``sources`` (relative paths)."""
    graph = {}
    for rel, text in sources.items():
        package = Path(rel).parent
        deps = set()
        for dots, name, grouped, plain in _IMPORT.findall(text):
            names = grouped or plain
            mod = _module_file(root, package, dots, name)
            if mod is not None:
                deps.add(mod)
            # ``from . import ball`` imports modules, not names
            for sub in re.split(r"[\s,]+", names.strip()):
                if sub:
                    m = _module_file(root, package, dots, (name + "." if name else "") + sub)
                    if m is not None:
                        deps.add(m)
        graph[rel] = deps
    return graph


def stale_files(changed, graph):
    """``changed`` and every file that imports one of them, transitively."""
    importers = {}
    for f, deps in graph.items():
        for d in deps:
            importers.setdefault(d, set()).add(f)
    stale, todo = set(changed), list(changed)
    while todo:
        f = todo.pop()
        for g in importers.get(f, ()):
            if g not in stale:
                stale.add(g)
                todo.append(g)
    return stale


def _drop_cached(root, rel):
    """Delete the cached kernels Numba made for source file ``rel``."""
    path = root / rel
    cache = path.parent / "__pycache__"
    if not cache.is_dir():
        return
    for pattern in (f"{path.stem}.*.nbi", f"{path.stem}.*.nbc"):
        for f in cache.glob(pattern):
            f.unlink(missing_ok=True)


def invalidate_stale_kernels(root=Path(__file__).parent):
    """Delete the cached kernels (``*.nbi``, ``*.nbc``) of every source file that changed
    since they were made, and of the files importing it. Returns the set of files whose
    kernels were dropped."""
    try:
        sources = _numba_sources(root)
        stamps = {rel: "%d:%d" % ((root / rel).stat().st_size, (root / rel).stat().st_mtime_ns)
                  for rel in sources}
        cache = root / "__pycache__"
        stamp_file = cache / _STAMP
        try:
            old = json.loads(stamp_file.read_text())
        except (OSError, ValueError):
            old = None
        if old == stamps:
            return set()
        if old is None:          # no record: nothing cached can be trusted
            stale = set(sources)
            for pattern in ("*.nbi", "*.nbc"):
                for f in root.rglob(pattern):
                    f.unlink(missing_ok=True)
        else:
            changed = {rel for rel in sources if old.get(rel) != stamps[rel]}
            changed |= {rel for rel in old if rel not in sources}
            stale = stale_files(changed, import_graph(root, sources))
            for rel in stale:
                _drop_cached(root, rel)
        cache.mkdir(exist_ok=True)
        tmp = cache / f"{_STAMP}.{os.getpid()}"
        tmp.write_text(json.dumps(stamps, sort_keys=True))
        os.replace(tmp, stamp_file)
        return stale
    except OSError:
        # A read-only install: Numba then caches elsewhere or not at all; nothing to clean.
        return set()
