"""The package as a user gets it: ``pip wheel .``, installed in a fresh venv, ``mavhelm demo``
run from another folder with no repository around, and the web page's files found.

The fresh venv takes the wheel alone (``--no-deps``); its dependencies (numpy, pymavlink, …)
come from the test's own environment through a ``.pth`` line, so the test needs no download
beyond pip's build of the wheel, and mavhelm itself can only come from the wheel.
"""

from __future__ import annotations

import site
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]


def run(*cmd: str | Path, cwd: Path, timeout: float = 600) -> str:
    done = subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env={"PATH": "/usr/bin:/bin", "HOME": str(cwd)})
    assert done.returncode == 0, f"{cmd}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done.stdout


def test_the_wheel_installs_and_runs_the_demo_from_anywhere(tmp_path):
    wheels = tmp_path / "wheels"
    run(sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", wheels, REPO, cwd=tmp_path)
    wheel = next(wheels.glob("mavhelm-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    for shipped in ("mavhelm/demo/demo.moos", "mavhelm/companion/web/static/index.html",
                    "mavhelm/companion/web/static/picture.js"):
        assert shipped in names, shipped
    venv = tmp_path / "venv"
    run(sys.executable, "-m", "venv", "--without-pip", venv, cwd=tmp_path)
    python = venv / "bin" / "python"
    packages = Path(run(python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))",
                        cwd=tmp_path).strip())
    (packages / "deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    run(sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", wheel,
        cwd=tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    where = run(python, "-c", "import mavhelm; print(mavhelm.__file__)", cwd=elsewhere)
    assert str(packages) in where, where
    out = run(venv / "bin" / "mavhelm", "demo", "--fast-start", "--out", "runs", cwd=elsewhere)
    assert "EndMission" in out or "MISSION" in out.upper(), out[-2000:]
    assert list((elsewhere / "runs").glob("*/track.png")), out[-2000:]
    page = run(python, "-c", "from importlib import resources; print(resources.files("
               "'mavhelm.companion.web').joinpath('static', 'index.html').read_text()[:15])",
               cwd=elsewhere)
    assert page.startswith("<!doctype html>")
