"""Building the documentation site and looking at it in a real browser (not named site.py:
that is a standard module).

    python tests/docs/docsite.py build [DIR]          # mkdocs build --strict into DIR
    python tests/docs/docsite.py screenshots          # docs/images/site-*.png, from a build
                                                   # that runs the tutorials (quick)

The tests (test_site.py) use the same functions: a strict build, every page of the nav
present, every internal link and anchor resolving, and Chromium (headless, Debian's) drawing
the pages.
"""
import contextlib
import functools
import html.parser
import http.server
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import urllib.parse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--hide-scrollbars"]


def build(site_dir, *, execute=False, quick=True, timeout=900):
    """``mkdocs build --strict`` into ``site_dir``; returns the CompletedProcess (its
    output holds mkdocs' log). ``execute`` runs the tutorials while building (their
    outputs go into the pages), ``quick`` in their short version."""
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    env["TUMBLE_DOCS_EXECUTE"] = "true" if execute else "false"
    if quick:
        env["TUMBLE_DOCS_QUICK"] = "1"
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(site_dir)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


class _Links(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.links, self.ids = [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        for key in ("href", "src"):
            if a.get(key) and not (tag == "link" and a.get("rel") == "canonical"):
                self.links.append(a[key])


@functools.lru_cache(maxsize=None)
def _parse(path):
    p = _Links()
    p.feed(Path(path).read_text(errors="replace"))
    return p


def page_file(site_dir, url_path):
    """The file a site-relative URL path serves (``x/`` -> ``x/index.html``), or None."""
    f = Path(site_dir) / urllib.parse.unquote(url_path).lstrip("/")
    if f.is_dir():
        f = f / "index.html"
    return f if f.is_file() else None


def broken_links(site_dir):
    """Every internal link or anchor of the built site that leads nowhere, as strings
    'page: link'. External (http, mailto, data) links are not followed."""
    site_dir = Path(site_dir)
    bad = []
    for page in sorted(site_dir.rglob("*.html")):
        rel = page.relative_to(site_dir).as_posix()
        base = "/" + rel
        for link in _parse(str(page)).links:
            parts = urllib.parse.urlsplit(link)
            if parts.scheme or link.startswith("//"):
                continue
            target = urllib.parse.urljoin(base, parts.path) if parts.path else base
            f = page_file(site_dir, target)
            if f is None:
                bad.append(f"{rel}: {link}")
            elif parts.fragment and f.suffix == ".html" and \
                    urllib.parse.unquote(parts.fragment) not in _parse(str(f)).ids:
                bad.append(f"{rel}: {link} (no such anchor)")
    return bad


@contextlib.contextmanager
def serve(site_dir):
    """Serve ``site_dir`` on 127.0.0.1 (a free port); yields the base URL."""
    handler = functools.partial(_QuietHandler, directory=str(site_dir))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def chromium():
    """Debian's Chromium, or None."""
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


def screenshot(url, path, size=(1280, 900), timeout=120):
    """A PNG of ``url`` as headless Chromium draws it, written to ``path``."""
    exe = chromium()
    if exe is None:
        raise RuntimeError("Chromium is not installed (apt-get install chromium)")
    with tempfile.TemporaryDirectory() as profile:
        cmd = [exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
               f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=5000",
               f"--screenshot={path}", url]
        subprocess.run(cmd, check=True, capture_output=True, timeout=timeout)
    return path


def main(argv):
    what = argv[0] if argv else "build"
    if what == "build":
        out = Path(argv[1]) if len(argv) > 1 else ROOT / "build" / "site"
        r = build(out)
        print(r.stderr[-3000:])
        bad = broken_links(out)
        print("\n".join(bad) or "all internal links resolve")
        return r.returncode or bool(bad)
    if what == "screenshots":
        images = ROOT / "docs" / "images"
        with tempfile.TemporaryDirectory() as tmp:
            r = build(tmp, execute=True)
            if r.returncode:
                print(r.stderr[-5000:])
                return 1
            with serve(tmp) as url:
                screenshot(f"{url}/", images / "site-front-page.png")
                # the top of tutorial 1: text, code, what it prints, the World's picture
                screenshot(f"{url}/tutorials/t01_rigid_bodies/", images / "site-tutorial.png",
                           size=(1280, 2000))
        print(f"written: {images / 'site-front-page.png'}, {images / 'site-tutorial.png'}")
        return 0
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
