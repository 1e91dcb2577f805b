"""The wheel installs under its own namespace (``cyborg.*``): beside python-daemon (whose
import name is ``daemon``, as our folder's is), neither overwrites the other, and
uninstalling either leaves the other whole.

A real wheel, a fresh venv, real installs from the package index (skipped, saying why,
where the index cannot be reached).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
pytestmark = pytest.mark.timeout(900)


EMPTY = Path(tempfile.mkdtemp(prefix="cyborg-install-"))
"""Where the installed programs run: in the checkout, its ``daemon/`` folder would shadow
python-daemon's ``daemon`` (the current folder comes first on ``sys.path``)."""


def _run(*args: str | Path, check: bool = True) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(a) for a in args], capture_output=True, text=True, check=check, cwd=EMPTY
    )


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    built = _run(
        sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", out, ROOT, check=False
    )
    if built.returncode != 0:
        pytest.skip(f"cannot build the wheel here (package index?): {built.stderr.strip()[-300:]}")
    return next(out.glob("cyborg_astrobiologist-*.whl"))


def test_the_wheel_has_no_top_level_daemon_clients_or_protocol(wheel: Path) -> None:
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/", 1)[0] for n in names if "/" in n and ".dist-info" not in n}
    assert tops == {"cyborg"}, tops
    assert "cyborg/daemon/__main__.py" in names and "cyborg/protocol/foxglove/Log.json" in names
    assert "cyborg/clients/operator/static/app.js" in names


def test_beside_python_daemon_each_survives_the_other(wheel: Path, tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    _run(sys.executable, "-m", "venv", venv)
    pip, python = venv / "bin" / "pip", venv / "bin" / "python"
    first = _run(pip, "install", "-q", "python-daemon", wheel, check=False)
    if first.returncode != 0:
        pytest.skip(f"cannot install from the package index here: {first.stderr.strip()[-300:]}")
    theirs = "import daemon; assert daemon.DaemonContext; print('python-daemon ok')"
    ours = (
        "from cyborg.daemon.worker import VisionWorker; "
        "from cyborg.protocol.version import PROTOCOL_MAJOR; print('ours ok')"
    )

    def works(code: str) -> bool:
        return _run(python, "-c", code, check=False).returncode == 0

    assert works(theirs) and works(ours)
    for script in ("cyborgd", "cyborg"):
        assert "protocol" in _run(venv / "bin" / script, "--version").stdout
    _run(pip, "uninstall", "-y", "-q", "python-daemon")
    assert works(ours) and not works(theirs)
    assert "protocol" in _run(venv / "bin" / "cyborgd", "--version").stdout
    _run(pip, "install", "-q", "python-daemon")
    _run(pip, "uninstall", "-y", "-q", "cyborg-astrobiologist")
    assert works(theirs) and not works(ours)


def test_every_package_folder_is_listed_for_the_wheel() -> None:
    """pyproject.toml lists the packages (discovery cannot add the ``cyborg.`` prefix)."""
    listed = set(
        tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = {
        "cyborg." + ".".join(init.parent.relative_to(ROOT).parts)
        for top in ("daemon", "clients", "protocol")
        for init in (ROOT / top).rglob("__init__.py")
    }
    assert listed == found
