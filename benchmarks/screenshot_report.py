"""The HTML report of the HFB-320 deck: written by ``mlid run --report``,
rendered by headless Chromium to PNG tiles, and the time to write the report
against the time of the fits (medians, side by side in one run).

    python benchmarks/screenshot_report.py [--deck DECK] [--out DIR] [--repeats N]

Needs chromium (Debian: apt-get install chromium) and the shared data; not
part of CI.
"""

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import median  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT / "cases" / "hfb320" / "hfb320.nml"
MLID = Path(sys.executable).with_name("mlid")
WIDTH, TILE = 1280, 1800


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    raise SystemExit("screenshot_report: no chromium (Debian: apt-get install chromium)")


def render(page, png, height=40000):
    """A screenshot of the whole page (a tall window), blank bottom cut off."""
    subprocess.run([chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                    "--hide-scrollbars", f"--window-size={WIDTH},{height}",
                    f"--screenshot={png}", page.as_uri()],
                   check=True, capture_output=True, timeout=300)
    import matplotlib.image as mi
    img = mi.imread(png)
    ink = np.flatnonzero((img[..., :3] < 0.98).any(axis=(1, 2)))
    img = img[:ink[-1] + 40] if ink.size else img
    mi.imsave(png, img)
    tiles = []
    for k, top in enumerate(range(0, len(img), TILE)):
        tile = png.with_name(f"{png.stem}_{k + 1}.png")
        mi.imsave(tile, img[top:top + TILE])
        tiles.append(tile)
    return img.shape, tiles


def timing(deck, folder, repeats):
    """Median seconds of running the deck's fits and of writing its report."""
    import matplotlib
    matplotlib.use("Agg")
    from mlid.cli.deck import run_deck
    from mlid.report.html_report import write_report
    cases = run_deck(deck)
    fit = median(lambda: run_deck(deck), repeats)
    report = median(lambda: write_report(folder, deck, cases), repeats)
    return fit, report


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--deck", default=str(DECK))
    p.add_argument("--out", help="folder for the page and PNGs (default a temporary one)")
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args(argv)
    out = Path(args.out or tempfile.mkdtemp(prefix="mlid_report_"))
    deck = Path(args.deck).resolve()
    t0 = time.perf_counter()
    run = subprocess.run([str(MLID), "run", str(deck), "--report", str(out)],
                         capture_output=True, text=True)
    print(f" mlid run --report: exit {run.returncode}, {time.perf_counter() - t0:.1f} s")
    page = out / f"{deck.stem}.html"
    if not page.is_file():
        print(run.stderr, file=sys.stderr)
        return 1
    print(f" page: {page} ({page.stat().st_size / 1e6:.2f} MB)")
    shape, tiles = render(page, out / f"{deck.stem}.png")
    print(f" screenshot: {out / (deck.stem + '.png')} ({shape[1]} x {shape[0]} px), tiles:")
    for tile in tiles:
        print(f"   {tile}")
    fit, report = timing(deck, out / "timing", args.repeats)
    print(f" median of {args.repeats}: fits {fit:.2f} s, report {report:.2f} s, "
          f"report/fit {report / fit:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
