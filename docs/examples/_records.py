"""Where the gallery's examples find the repository's cases and the shared flight records
(``../shared/data`` beside the repository; None where it is not there)."""

from pathlib import Path

try:
    HERE = Path(__file__).resolve().parent
except NameError:                      # sphinx-gallery runs an example with its folder as cwd
    HERE = Path.cwd()
ROOT = HERE.parents[1]
CASES = ROOT / "cases"
_DATA = ROOT.parent / "shared" / "data"
DATA = _DATA if (_DATA / "fAttasElv1.mat").is_file() else None
