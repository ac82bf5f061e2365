"""Keep Numba's on-disk cache consistent with the package sources.

Numba keys a cached kernel on the file that defines it, not on the files of the kernels
it inlines, so editing ``integrate.py`` would leave ``step.py``'s cached step running
the old code. On import we compare every Numba-using source file of the package with the
stamp recorded when its kernels were cached, and drop the cached kernels of each changed
file and of every file that imports one (directly or through others): their compiled
code may hold the changed functions. Editing a pure-Python file (a loader, the viewer)
keeps every compiled kernel; editing one pipeline stage recompiles that stage and the
step, not the collision routines.

Numba keeps the kernels of ``dir/x.py`` (index ``x.<qualname>-<line>.pyXY.nbi``, data
``x.<qualname>-<line>.pyXY.<n>.nbc``) in the first of these that it can write to:

* ``$NUMBA_CACHE_DIR/<dir's name>_<sha1 of dir's absolute path>/`` if that is set;
* ``dir/__pycache__/`` (in-tree);
* the same mirrored folder under the user-wide cache (``~/.cache/numba`` on Linux).

Each of those places (a location) has its own stamp, beside the kernels of the package's
top-level files (``__pycache__/tumble-sources.json`` in-tree), telling which sources the
kernels there were made from. A location is checked against its own stamp: a process
that cached elsewhere (another ``NUMBA_CACHE_DIR``, none) leaves it alone, and it is
checked when it is in use again. Its stamp is written only once its stale kernels are
deleted, so a location that could not be cleaned is tried again on the next import; one
without a stamp (first seen, or cached by an older tumble) keeps none of the package's
kernels. A Numba upgrade only recompiles: Numba ignores an index written by another
version, and if its internals moved we fall back to the layout described here.
"""
import hashlib
import json
import os
import re
import sys
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


def in_tree(src_dir):
    """The in-tree location: the kernels of the files in ``src_dir`` are in its
    ``__pycache__``."""
    return Path(src_dir) / "__pycache__"


def _cache_subpath(src_dir):
    """The folder Numba gives the kernels of the files in ``src_dir`` under a cache root
    (``_CacheLocator.get_suitable_cache_subpath``: the folder's name and the SHA-1 of its
    absolute path)."""
    py_file = os.path.join(os.path.abspath(src_dir), "x.py")
    try:
        from numba.core.caching import _CacheLocator
        return _CacheLocator.get_suitable_cache_subpath(py_file)
    except Exception:        # pragma: no cover - a Numba that moved its internals
        folder = os.path.dirname(py_file)
        return "_".join([os.path.basename(folder), hashlib.sha1(folder.encode()).hexdigest()])


def mirrored(base):
    """A location that mirrors source folders under the cache root ``base`` (Numba's
    ``NUMBA_CACHE_DIR`` and user-wide caches)."""
    base = Path(base)
    return lambda src_dir: base / _cache_subpath(src_dir)


def _numba_cache_dir():
    """Numba's ``NUMBA_CACHE_DIR`` (from the environment or a ``.numba_config.yaml``), or ''."""
    try:
        from numba.core import config
        return config.CACHE_DIR or ""
    except Exception:        # pragma: no cover - a Numba that moved its internals
        return os.environ.get("NUMBA_CACHE_DIR", "")


def _user_cache_dir():
    """Numba's user-wide cache, where it caches when the source tree is not writable."""
    try:
        from numba.misc.appdirs import AppDirs
        return AppDirs(appname="numba", appauthor=False).user_cache_dir
    except Exception:        # pragma: no cover - a Numba that moved its internals
        if sys.platform == "win32":
            return os.path.join(os.environ.get("LOCALAPPDATA", os.path.expanduser("~")),
                                "numba", "Cache")
        if sys.platform == "darwin":
            return os.path.expanduser("~/Library/Caches/numba")
        return os.path.join(os.getenv("XDG_CACHE_HOME", os.path.expanduser("~/.cache")),
                            "numba")


def _writable(folder):
    """Whether Numba could cache in ``folder`` (it makes it if need be)."""
    while not folder.exists() and folder.parent != folder:
        folder = folder.parent
    return os.access(folder, os.W_OK)


def _kernel_files(folder, stem=None):
    """Numba's index and data files in ``folder``: those of the source file named ``stem``
    (``<stem>.<qualname>-<line>.pyXY.nbi`` and ``...<n>.nbc``, with a ``<prefix>-`` in
    front for a library cache such as ``guf-``), or all of them if ``stem`` is None."""
    try:
        names = os.listdir(folder)
    except FileNotFoundError:
        return []
    mine = re.compile(r"(?:\w+-)?%s\..*\.nb[ic]\Z" % re.escape(stem) if stem is not None
                      else r".*\.nb[ic]\Z")
    return [Path(folder) / n for n in names if mine.match(n)]


def _drop_cached(root, rel, location=in_tree):
    """Delete the cached kernels Numba made for source file ``rel`` in ``location`` (in-tree
    by default). Raises OSError if one cannot be deleted."""
    path = root / rel
    for f in _kernel_files(location(path.parent), path.stem):
        f.unlink(missing_ok=True)


def _drop_all(root, sources, location):
    """Delete every cached kernel of the package in ``location``."""
    if location is in_tree:
        for pattern in ("*.nbi", "*.nbc"):
            for f in root.rglob(pattern):
                f.unlink(missing_ok=True)
        return
    for folder in {location(root)} | {location((root / rel).parent) for rel in sources}:
        for f in _kernel_files(folder):
            f.unlink(missing_ok=True)


def _refresh(root, sources, stamps, location, graph):
    """Bring one location up to date with the sources: drop the kernels made from sources
    that changed since its stamp (and from their importers), then write the stamp.
    Returns the files whose kernels were dropped; raises OSError, without writing the
    stamp, if the location cannot be cleaned or stamped."""
    stamp_file = location(root) / _STAMP
    try:
        old = json.loads(stamp_file.read_text())
    except (OSError, ValueError):
        old = None
    if old == stamps:
        return set()
    if not isinstance(old, dict):    # no record: nothing cached there can be trusted
        stale = set(sources)
        _drop_all(root, sources, location)
    else:
        changed = {rel for rel in sources if old.get(rel) != stamps[rel]}
        changed |= {rel for rel in old if rel not in sources}
        stale = stale_files(changed, graph())
        for rel in stale:
            _drop_cached(root, rel, location)
    stamp_file.parent.mkdir(parents=True, exist_ok=True)
    tmp = stamp_file.with_name(f"{_STAMP}.{os.getpid()}")
    tmp.write_text(json.dumps(stamps, sort_keys=True))
    os.replace(tmp, stamp_file)
    return stale


def invalidate_stale_kernels(root=Path(__file__).parent):
    """Delete the cached kernels (``*.nbi``, ``*.nbc``) of every source file that changed
    since they were made, and of the files importing it, wherever Numba may load them
    from: in-tree, under ``NUMBA_CACHE_DIR`` if set, and in the user-wide cache if it
    holds any of the package's kernels or the tree cannot be written. Returns the set of
    files whose kernels were dropped."""
    try:
        sources = _numba_sources(root)
        stamps = {}
        for rel in sources:
            st = (root / rel).stat()
            stamps[rel] = "%d:%d" % (st.st_size, st.st_mtime_ns)
    except OSError:
        return set()
    graph_memo = []

    def graph():
        if not graph_memo:
            graph_memo.append(import_graph(root, sources))
        return graph_memo[0]

    dropped = set()
    tree_ok = _writable(in_tree(root))
    try:
        dropped |= _refresh(root, sources, stamps, in_tree, graph)
    except OSError:
        # A read-only install: Numba caches in NUMBA_CACHE_DIR, the user-wide cache, or not
        # at all.
        tree_ok = False
    folders = {root} | {(root / rel).parent for rel in sources}
    done = set()
    for base, needed in ((_numba_cache_dir(), True), (_user_cache_dir(), not tree_ok)):
        if not base:
            continue
        location = mirrored(base)
        where = location(root)
        if where in done or not (needed or any(location(d).is_dir() for d in folders)):
            continue
        done.add(where)
        try:
            dropped |= _refresh(root, sources, stamps, location, graph)
        except OSError:
            # Not writable: Numba cannot cache there either, or it is tried again next time.
            pass
    return dropped
