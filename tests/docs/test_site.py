"""The documentation site: it builds with ``mkdocs build --strict`` (no warnings, no broken
cross-reference), every page of the nav and every public name of the API is there, every
internal link and anchor resolves, Chromium draws it, and the getting-started page's
commands run and print what the page says.
"""
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mkdocs")
pytest.importorskip("mkdocstrings")
pytest.importorskip("mkdocs_jupyter")

import docsite as docs_site  # noqa: E402  (tests/docs/docsite.py)

ROOT = docs_site.ROOT


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    r = docs_site.build(out)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-5000:]
    log = r.stderr + r.stdout
    assert "WARNING" not in log, log
    return out


def nav_pages():
    import yaml

    class Loader(yaml.SafeLoader):
        pass
    Loader.add_multi_constructor("!", lambda loader, suffix, node: None)   # !ENV
    config = yaml.load((ROOT / "mkdocs.yml").read_text(), Loader=Loader)
    pages = []

    def walk(items):
        for item in items:
            if isinstance(item, str):
                pages.append(item)
            else:
                for v in item.values():
                    walk(v) if isinstance(v, list) else pages.append(v)
    walk(config["nav"])
    return pages


def test_every_nav_page_is_built(built):
    pages = nav_pages()
    assert len(pages) >= 25
    for src in pages:
        stem = src.rsplit(".", 1)[0]
        url = "" if stem == "index" else (stem[:-len("index")] if stem.endswith("/index")
                                          else stem + "/")
        f = docs_site.page_file(built, url)
        assert f is not None, f"{src} was not built"
        text = f.read_text()
        assert "<h1" in text and len(text) > 5000, src
    # every tutorial file is in the nav
    tutorials = {p.name for p in (ROOT / "docs" / "tutorials").glob("t[0-9][0-9]_*.py")}
    assert tutorials == {Path(p).name for p in pages if p.endswith(".py")}


def test_internal_links_and_anchors_resolve(built):
    assert docs_site.broken_links(built) == []


def test_the_front_page_links_every_section(built):
    html = (built / "index.html").read_text()
    for target in ("getting-started/", "tutorials/", "concepts/models/", "api/",
                   "concepts/benchmarks/", "images/site-front-page.png",
                   "images/site-tutorial.png"):
        assert f'href="{target}' in html, target


def api_ids(built, page):
    return docs_site._parse(str(built / "api" / page / "index.html")).ids


def test_the_api_reference_has_every_public_name(built):
    import tumble
    import tumble.character
    import tumble.rl
    import tumble.viewer
    top = api_ids(built, "tumble")
    own = {n for n in tumble.__all__ if n not in tumble.character.__all__
           and n not in ("Recorder", "Recording", "__version__")}
    assert {f"tumble.{n}" for n in own} <= top
    assert "tumble.world.Options" in top
    character = api_ids(built, "character")
    assert {f"tumble.character.{n}" for n in tumble.character.__all__} <= character
    viewer = api_ids(built, "viewer")
    lazy = {"Viewer": "app", "view": "app", "export_video": "export", "Camera": "render",
            "Renderer": "render", "plots": None}
    for n in tumble.viewer.__all__:
        anchor = (f"tumble.viewer.{n}" if n not in lazy or lazy[n] is None
                  else f"tumble.viewer.{lazy[n]}.{n}")
        assert anchor in viewer, anchor
    assert "tumble.viewer.notebook.Animation" in viewer
    rl = api_ids(built, "rl")
    assert {f"tumble.rl.{n}" for n in tumble.rl.__all__} <= rl
    for name in ("train.TrainConfig", "train.Trainer", "train.evaluate", "train.train",
                 "policy.Policy", "play.load_policy", "play.policy_world",
                 "play.PolicyDriver"):
        assert f"tumble.rl.{name}" in rl, name


def test_tutorial_pages_show_their_code_and_a_download(built):
    html = (built / "tutorials" / "t01_rigid_bodies" / "index.html").read_text()
    assert "spinning_box" in html and "Dzhanibekov" in html
    assert (built / "tutorials" / "t01_rigid_bodies" / "t01_rigid_bodies.py").is_file()


def test_chromium_draws_the_site(built, tmp_path):
    if docs_site.chromium() is None:
        pytest.skip("no Chromium (apt-get install chromium)")
    from matplotlib.image import imread
    with docs_site.serve(built) as url:
        for page in ("", "tutorials/t05_pd_control/"):
            path = docs_site.screenshot(f"{url}/{page}", tmp_path / "shot.png",
                                        size=(1000, 700))
            img = imread(path)[..., :3]
            assert img.shape[:2] == (700, 1000)
            # drawn: a header bar and text, not a blank or an error page
            assert img.std() > 0.05 and (img.mean(axis=2) < 0.3).mean() > 0.005


def code_blocks(md, lang):
    return re.findall(rf"```{lang}\n(.*?)```", md, flags=re.S)


def test_getting_started_path(tmp_path):
    """The getting-started page's steps 2 to 5, as written (step 1, the install, is what
    this test environment already is)."""
    md = (ROOT / "docs" / "getting-started.md").read_text()
    shell = [c.strip() for c in code_blocks(md, "bash")]
    assert shell[0] == 'pip install ".[viewer]"'
    assert shell[1] == "tumble demo"
    out = subprocess.run([sys.executable, "-m", "tumble", "demo"], capture_output=True,
                         text=True, timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    flips = int(re.search(r"(\d+) half-turn flips", out.stdout).group(1))
    assert flips >= 2

    py = code_blocks(md, "python")
    assert len(py) == 2
    out = subprocess.run([sys.executable, "-c", "\n".join(py)], capture_output=True,
                         text=True, timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    z = float(re.search(r"rests at z = ([\d.]+) m", out.stdout).group(1))
    assert abs(z - 0.1) < 1e-3
    walked = re.search(r"walked ([\d.]+) s: ([\d.]+) m, speed ([\d.]+) m/s", out.stdout)
    assert walked, out.stdout
    assert float(walked.group(1)) == pytest.approx(10.0) and float(walked.group(2)) > 3.0

    cmd = shell[2].split()
    assert cmd[:2] == ["python", "examples/walk.py"]
    gif = tmp_path / "walk.gif"
    out = subprocess.run([sys.executable, str(ROOT / cmd[1]), *cmd[2:-1], str(gif)],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "FELL" not in out.stdout
    assert gif.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
