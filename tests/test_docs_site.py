"""The documentation site builds strictly (`make docs`: sphinx -W, every notebook executed, a warning or a
failing cell fails the build), and its pages work in headless Chromium: every image on every page loads, and
every link between pages of the site lands on a page that was built."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from urllib.parse import urldefrag, urlparse

import pytest

from _real_parts import chromium

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS),
                           str(out)], capture_output=True, text=True, timeout=1500)
    assert done.returncode == 0, done.stderr[-4000:]
    return out


@pytest.mark.slow
def test_the_site_builds_strictly_with_every_capability_and_notebook(site):
    for page in ("index", "getting-started", "capabilities/integrity", "capabilities/gnssdo", "capabilities/sync",
                 "capabilities/stability", "capabilities/monitor", "capabilities/positioning", "integrity/raim", "api",
                 "notebooks/stability_against_a_mask", "notebooks/watching_receivers_with_integrity"):
        assert (site / f"{page}.html").is_file(), page
    notebook = (site / "notebooks" / "stability_against_a_mask.html").read_text()
    assert "<img" in notebook  # its figure was drawn by the executed cell, not left out


@pytest.mark.slow
def test_every_page_of_the_site_loads_its_images_and_links_to_pages_that_exist(site, tmp_path):
    driver = chromium(tmp_path / "profile")
    try:
        pages = sorted(p for p in site.rglob("*.html") if "_static" not in p.parts and p.name not in (
            "genindex.html", "search.html", "py-modindex.html"))
        assert len(pages) > 20
        broken, missing = [], []
        for page in pages:
            driver.get(page.as_uri())
            driver.execute_async_script("""
                const done = arguments[arguments.length - 1];
                Promise.all([...document.images].map(i => i.complete ? 0 :
                    new Promise(r => { i.onload = i.onerror = r; }))).then(() => done());""")
            images = driver.execute_script("return [...document.images].map(i => [i.src, i.naturalWidth]);")
            broken += [(page.name, src) for src, width in images if width == 0]
            for href in driver.execute_script("return [...document.links].map(a => a.href);"):
                url = urlparse(urldefrag(href)[0])
                if url.scheme == "file" and not Path(url.path).exists():
                    missing.append((page.relative_to(site).as_posix(), url.path))
        assert not broken, broken[:10]
        assert not missing, missing[:10]
    finally:
        driver.quit()
