"""The documentation site: it builds with ``mkdocs build --strict`` (no broken link, anchor or
reference, no page left out of the navigation), and headless Chromium renders its home page and an
API page with the navigation and, on the home page, the picture (checked in the screenshot's
pixels, not only in the HTML: a missing image file or a theme that failed to load shows).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _helpers import run_chromium

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install -e '.[docs]')")
pytest.importorskip("mkdocstrings_handlers.python", reason="the docs extra is not installed")
pytestmark = pytest.mark.browser

#: Material's header colour with ``palette: primary: indigo`` (#4051b5).
INDIGO = np.array([64, 81, 181])


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--quiet", "--site-dir", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out


def _screenshot(tmp_path, page: Path, height: int) -> np.ndarray:
    import imageio.v3 as iio

    shot = tmp_path / "shot.png"
    run_chromium(tmp_path, f"--screenshot={shot}", f"--window-size=1280,{height}", url=page.as_uri())
    return iio.imread(shot)[..., :3].astype(int)


def _header_is_drawn(img: np.ndarray) -> bool:
    """The theme's indigo header band (the top navigation) covers the top of the page."""
    band = img[5:60]
    return float((np.abs(band - INDIGO).sum(axis=-1) < 40).mean()) > 0.8


def test_home_page_renders_navigation_and_the_picture(site, tmp_path):
    dom = run_chromium(tmp_path, "--dump-dom", url=(site / "index.html").as_uri())
    tabs = re.findall(r"md-tabs__link[^>]*>\s*([^<]*?)\s*<", dom)  # the top navigation
    assert tabs == ["Home", "Getting started", "Commands", "Science", "Results", "API", "Development"]
    assert 'src="img/push_hit.png"' in dom
    img = _screenshot(tmp_path, site / "index.html", 2000)
    assert _header_is_drawn(img)
    # the picture: its black sky makes wide runs of black pixels, which text never does
    black = (img.max(axis=-1) < 16).sum(axis=1)
    assert (black > 300).sum() > 100, (black > 300).sum()
    # the same check on a page without a picture does not pass (it is not vacuous)
    plain = _screenshot(tmp_path, site / "cli" / "index.html", 2000)
    assert ((plain.max(axis=-1) < 16).sum(axis=1) > 300).sum() == 0


def test_api_page_renders_the_docstrings(site, tmp_path):
    page = site / "api" / "control" / "index.html"
    dom = run_chromium(tmp_path, "--dump-dom", url=page.as_uri())
    assert "WorkspaceController" in dom and "doc-heading" in dom
    for name in ("biped.spatial", "biped.sim", "biped.errors"):  # the API section's navigation
        assert name in dom, name
    img = _screenshot(tmp_path, page, 1000)
    assert _header_is_drawn(img)
    # text was drawn: the content column is not blank
    assert (img[150:, 250:1000].max(axis=-1) < 100).sum() > 2000
