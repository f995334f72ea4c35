"""Phobos in a fresh Blender user folder, installed by scripts/install_phobos.py, as docs/blender.md says.

The ``blender`` binary (Debian's 3.4.1 runs the system's Python, where PEP 668 refuses Phobos's own pip)
gets a user folder of its own (BLENDER_USER_SCRIPTS / _CONFIG / _RESOURCES in a temporary folder).
PhyRoGen's add-on is enabled first, as the docs' order has it, then the command installs and enables
Phobos, so that Blender loads Phobos *after* PhyRoGen at every start. A background session with those
preferences then runs the panel's Generate, Phobos's own Export Model before anything of ours touched
Phobos, Validate, Re-plan, Export with Phobos and Export Model again; PyBullet loads Phobos's URDFs with
the puzzle's movable joints. Negative controls: Export Model without PhyRoGen enabled fails where
Phobos misdetects Blender; with Phobos's unpinned NumPy 2 in Blender's process, Validate fails with one
line naming it instead of a traceback. Needs the network (pip reaches PyPI): skips without it.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from blender_support import blender_environment, pybullet_model, tool

REPOSITORY = Path(__file__).resolve().parent.parent
VENDOR = REPOSITORY.parent / "shared" / "vendor"
BLENDER = tool("blender")
TARBALL = next(iter(sorted(VENDOR.glob("phobos-*.tar.gz"))[-1:]), None)
SESSION = REPOSITORY / "tests" / "blender_phobos_session.py"
ADDON = "phyrogen_blender"
"""The add-on's module name, as the legacy zip installs it (``phyrogen`` is the command line's package)."""

pytestmark = [pytest.mark.blender, pytest.mark.slow,
              pytest.mark.skipif(BLENDER is None, reason="no blender binary (apt-get install blender)"),
              pytest.mark.skipif(TARBALL is None, reason=f"Phobos's source is not at {VENDOR}/phobos-*.tar.gz")]


def _blender(environment: dict, *arguments: str, timeout: int = 600) -> subprocess.CompletedProcess:
    return subprocess.run([BLENDER, "--background", "--python-exit-code", "1", *arguments],
                          capture_output=True, text=True, timeout=timeout, env=environment)


def _session(home: Path, environment: dict, mode: str) -> dict:
    result = home / f"{mode}.json"
    run = _blender(environment, "--python", str(SESSION), "--", str(result), str(home / mode), mode)
    assert result.is_file(), run.stdout[-4000:] + run.stderr[-4000:]
    return {**json.loads(result.read_text()), "log": run.stdout + run.stderr}


@pytest.fixture(scope="module")
def user_folder(tmp_path_factory):
    """A fresh Blender user folder with PhyRoGen enabled, then Phobos installed by the command."""
    home = tmp_path_factory.mktemp("fresh-blender")
    environment = blender_environment(home)
    environment["PYTHONUSERBASE"] = str(home / "userbase")  # Phobos runs ``ensurepip --user`` at start
    # Debian's Blender runs the first python3.11 on PATH: Debian's own (PEP 668 applies), as for a user.
    environment["PATH"] = os.pathsep.join(["/usr/bin", environment.get("PATH", "")])
    shutil.copytree(REPOSITORY / "blender_addon", home / "scripts" / "addons" / ADDON,
                    ignore=shutil.ignore_patterns("__pycache__"))
    run = _blender(environment, "--python-expr",
                   f"import bpy; bpy.ops.preferences.addon_enable(module={ADDON!r}); bpy.ops.wm.save_userpref()")
    assert run.returncode == 0, run.stderr[-3000:]
    install = subprocess.run([sys.executable, str(REPOSITORY / "scripts" / "install_phobos.py"), "--blender",
                              BLENDER, "--phobos", str(TARBALL)],
                             capture_output=True, text=True, timeout=1200, env=environment)
    if install.returncode != 0 and "pip could not install" in install.stderr:
        pytest.skip(f"pip could not install Phobos's requirements (is PyPI reachable?): {install.stderr.strip()}")
    assert install.returncode == 0, install.stdout[-3000:] + install.stderr[-3000:]
    assert "enabled in Blender" in install.stdout
    return home, environment


def test_installed_phobos_runs_every_step_in_a_background_session(user_folder):
    home, environment = user_folder
    result = _session(home, environment, "full")
    assert result["steps"] and all(outcome == "ok" for _, outcome in result["steps"]), result["steps"]
    # Phobos loaded after PhyRoGen, and recognised Blender before any Export with Phobos ran.
    assert result["addons"].index(ADDON) < result["addons"].index("phobos")
    assert result["recognised_at_start"] is True
    assert "phyrogen-phobos-" not in result["executable"]  # sys.executable restored
    assert "PhyRoGen: Phobos reloaded so that it recognises this Blender" in result["log"]
    assert "externally-managed-environment" not in result["log"]
    if Path("/usr/bin/python3.11").exists() and Path("/usr/lib/python3.11/EXTERNALLY-MANAGED").exists():
        assert result["executable"] == "/usr/bin/python3.11"  # the Python that PEP 668 protects
    name = "simple_slider_5"
    ours = pybullet_model(home / "full" / "simple_slider" / name / "urdf" / f"{name}.urdf")
    movable = {joint: info for joint, info in ours["joints"].items() if info["type"] != 4}  # 4: fixed
    assert movable
    for urdf in (Path(result["export_model_first"]), Path(result["export_model"]),
                 home / "full" / "simple_slider" / name / "phobos" / "urdf" / f"{name}.urdf"):
        theirs = pybullet_model(urdf)["joints"]
        for joint, info in movable.items():
            assert (theirs[joint]["type"], theirs[joint]["child"]) == (info["type"], info["child"]), (urdf, joint)
            assert theirs[joint]["limits"] == pytest.approx(info["limits"], abs=1e-5), (urdf, joint)
            assert theirs[joint]["axis"] == pytest.approx(info["axis"], abs=1e-6), (urdf, joint)


def test_phobos_misdetects_blender_without_the_add_on(user_folder, tmp_path):
    """The control: the same user folder with PhyRoGen's add-on disabled leaves Phobos misdetecting this
    Blender (so its Export Model fails: tests/test_phobos_export.py shows the error)."""
    home, environment = user_folder
    environment = {**environment, "BLENDER_USER_CONFIG": str(tmp_path / "config")}
    shutil.copytree(home / "config", tmp_path / "config")
    run = _blender(environment, "--python-expr", f"import bpy; bpy.ops.preferences.addon_disable(module={ADDON!r}); "
                   "bpy.ops.wm.save_userpref()")
    assert run.returncode == 0, run.stderr[-3000:]
    run = _blender(environment, "--python-expr", "import bpy, sys; print('ADDONS', *bpy.context.preferences.addons."
                   "keys()); print('RECOGNISED', sys.modules['phobos.defs'].BPY_AVAILABLE)")
    assert "RECOGNISED False" in run.stdout, run.stdout[-3000:] + run.stderr[-3000:]
    assert ADDON not in run.stdout.split("ADDONS", 1)[1].splitlines()[0].split()


def test_validate_names_an_incompatible_numpy_in_one_line(user_folder):
    """Phobos's own install (unpinned) puts NumPy 2.x first on Blender's path: Validate then reports it."""
    home, environment = user_folder
    modules = home / "scripts" / "modules"
    run = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
                          "--no-deps", "--upgrade", "--target", str(modules), "numpy>=2.3,<2.5"],
                         capture_output=True, text=True, timeout=900)
    if run.returncode != 0:
        pytest.skip(f"pip could not install NumPy 2: {run.stderr.strip()[-300:]}")
    try:
        result = _session(home, environment, "validate")
    finally:  # back to the command's NumPy for any later test of this folder
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps",
                        "--upgrade", "--target", str(modules), "numpy>=1.24,<2"], capture_output=True, timeout=900)
    steps = dict(result["steps"])
    assert steps["generate"] == "ok", steps
    # bpy.ops raises the operator's error report as "Error: <report>\n".
    message = steps["validate"].removeprefix("RuntimeError: Error: ").removesuffix("\n")
    assert message.startswith("Validate cannot load PhyRoGen's checker in this Blender: Numba needs NumPy"), message
    assert "\n" not in message and "NumPy 2." in message and "install_phobos.py" in message, message
    assert "Traceback" not in result["log"], result["log"][-3000:]
