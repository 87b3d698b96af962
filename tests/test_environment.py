"""The environment `mlid run` meets (issue 41, class 10)."""

import os
import subprocess

from conftest import BIN, two_case_deck


def test_an_unwritable_home_says_nothing_about_matplotlib(tmp_path):
    """Issue 41, class 10: with a HOME no folder can be made in, `mlid run
    --plots` draws its plots and says nothing of matplotlib's settings
    folder (matplotlib made a temporary one on every run and said so)."""
    deck = tmp_path / "deck.nml"
    deck.write_text(two_case_deck())
    env = {k: v for k, v in os.environ.items()
           if k not in ("MPLCONFIGDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")}
    env["HOME"] = "/proc/no_such_home"            # /proc takes no new folder, even for root
    run = subprocess.run([str(BIN / "mlid"), "run", deck.name, "--plots", "plots"],
                         capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "matplotlib" not in run.stderr.lower(), run.stderr
    assert (tmp_path / "plots" / "case2_fit.png").is_file()
