import subprocess

import mlid
from conftest import BIN


def test_imports_installed_package_not_checkout():
    assert "site-packages" in mlid.__file__, mlid.__file__


def test_cli_help_lists_jobs():
    out = subprocess.run([str(BIN / "mlid"), "--help"], capture_output=True, text=True)
    assert out.returncode == 0
    assert "run DECK" in out.stdout and "estimate" in out.stdout and "simulate" in out.stdout


def test_batch_executable_installed():
    out = subprocess.run([str(BIN / "mlid-batch"), "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "usage: mlid-batch" in out.stdout


def test_defaults_come_from_the_core():
    opts = mlid.default_options()
    assert opts["max_iter"] > 0 and opts["noise"] == "diagonal" and 0 < opts["rcond"] < 1
