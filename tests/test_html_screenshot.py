"""The HTML report of the C-8 deck in a headless browser (Debian's chromium;
skipped only where it is not installed: `make sysdeps` installs it): the
screenshot is a page, not a blank, holding the figures' pixels, and every
<img> of the page loaded (the browser's own word, from its DOM)."""

import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO

DECK = REPO / "cases" / "c8_short_period" / "c8.nml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
WIDTH, HEIGHT = 1280, 9000
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed "
                                "(Debian: apt-get install chromium, or make sysdeps)")
# The figures' colours (mlid.report.plots.COLORS): the residuals' red, the
# inputs' green; the page's own style uses neither.
RESIDUAL, INPUT = (0xb2, 0x33, 0x2a), (0x2a, 0x8a, 0x3e)
# After load, the page's images as the browser has them: how many, and how
# many are broken (not complete, or no natural width).
PROBE = """<script>window.addEventListener("load", () => {
  const imgs = [...document.images];
  document.body.setAttribute("data-images", imgs.length);
  document.body.setAttribute("data-broken",
      imgs.filter(i => !i.complete || i.naturalWidth === 0).length);
  document.body.setAttribute("data-sizes", imgs.map(i => i.naturalWidth + "x" +
      i.naturalHeight).join(" "));
});</script>"""


def _chromium(tmp_path, *args):
    return subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                           "--hide-scrollbars", f"--user-data-dir={tmp_path / 'profile'}",
                           *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    work = tmp_path_factory.mktemp("screenshot")
    deck = work / "c8.nml"
    deck.write_text(DECK.read_text())
    p = subprocess.run([sys.executable, "-m", "mlid", "run", str(deck), "--report",
                        str(work / "report")], capture_output=True, text=True, cwd=work)
    assert p.returncode == 0, p.stderr
    return work / "report" / "c8.html"


def test_the_screenshot_is_the_page_with_its_figures(report, tmp_path):
    import matplotlib.image as mi
    png = tmp_path / "c8.png"
    p = _chromium(tmp_path, f"--window-size={WIDTH},{HEIGHT}", f"--screenshot={png}",
                  report.as_uri())
    assert png.is_file(), p.stderr
    img = mi.imread(png)[..., :3]
    assert img.shape == (HEIGHT, WIDTH, 3)
    rgb = np.round(img * 255).astype(int)
    assert rgb.std() > 20                                   # not a uniform image
    # the page ends inside the window (all of it is in the shot), and is as
    # tall as a page of eight figures
    ink = np.flatnonzero((rgb < 250).any(axis=(1, 2)))
    assert 3000 < ink[-1] < HEIGHT - 200, ink[-1]

    def near(colour, tol=10):
        return np.abs(rgb - np.array(colour)).max(axis=2) <= tol

    def pixels(colour):
        return int(near(colour).sum())
    # the residual traces, autocorrelation stems and spectra; the input trace
    assert pixels(RESIDUAL) > 5000, pixels(RESIDUAL)
    assert pixels(INPUT) > 50, pixels(INPUT)
    # the figures come after the tables of the fit, not over them
    rows = np.flatnonzero(near(RESIDUAL).sum(axis=1) >= 30)    # a trace, not a word
    assert rows.size and rows[0] > 1000, rows[:1]


def test_every_image_of_the_page_loads(report, tmp_path):
    page = tmp_path / "probe.html"
    page.write_text(report.read_text(encoding="ascii").replace("</body>", PROBE + "</body>"))
    p = _chromium(tmp_path, "--virtual-time-budget=20000", "--dump-dom", page.as_uri())
    body = re.search(r"<body([^>]*)>", p.stdout)
    assert body, p.stderr[-2000:]
    attrs = dict(re.findall(r'(data-[a-z]+)="([^"]*)"', body.group(1)))
    assert attrs.get("data-images") == "8", attrs           # the fit's eight figures
    assert attrs["data-broken"] == "0"
    # each drawn at the size its PNG has, as the page says
    said = re.findall(r'<img [^>]*width="(\d+)" height="(\d+)"', report.read_text())
    assert attrs["data-sizes"].split() == [f"{w}x{h}" for w, h in said]
