"""The self-contained extension: the zip bundles what Generate needs, and a fresh Blender with only the zip
installed generates a certified puzzle and re-plans it.

"Fresh Blender" is the bpy 4.5 wheel in a Python that holds nothing else: a new virtual environment whose
site-packages links bpy and the distributions bpy requires (what a Blender binary ships: numpy, requests,
zstandard, Cython), with an empty Blender user folder, no PYTHONPATH, no PHYROGEN_VENV and no VIRTUAL_ENV,
started in an empty folder. PhyRoGen, OMPL, numba and tqdm can come only from the extension's wheels.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import tomllib
import venv
import zipfile
from importlib import metadata
from pathlib import Path

import pytest
from blender_support import wheel_cache_lock

REPOSITORY = Path(__file__).resolve().parent.parent
BUILD_ADDON = REPOSITORY / "scripts" / "build_addon.py"


def _build_addon_module():
    spec = importlib.util.spec_from_file_location("build_addon", BUILD_ADDON)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_project_dependency_is_bundled_or_its_absence_explained():
    build_addon = _build_addon_module()
    names = set(build_addon.project_requirements())
    assert set(build_addon.BUNDLED) | set(build_addon.NOT_BUNDLED) == names
    assert not set(build_addon.BUNDLED) & set(build_addon.NOT_BUNDLED)
    assert set(build_addon.PROVIDED_BY_BLENDER) <= set(build_addon.NOT_BUNDLED)


def test_manifest_gets_platforms_and_wheels_before_its_tables():
    build_addon = _build_addon_module()
    manifest = (REPOSITORY / "blender_addon" / "blender_manifest.toml").read_text(encoding="utf-8")
    wheels = ["a-1.0-py3-none-any.whl", "b-2.0-cp311-cp311-manylinux2014_x86_64.whl"]
    parsed = tomllib.loads(build_addon.manifest_with_wheels(manifest, wheels))
    assert parsed["wheels"] == [f"./wheels/{name}" for name in wheels]
    assert parsed["platforms"] == [build_addon.PLATFORM]
    assert {k: v for k, v in parsed.items() if k not in ("wheels", "platforms")} == tomllib.loads(manifest)


@pytest.fixture
def no_environment(monkeypatch, tmp_path):
    """As in an installed extension: no virtual environment found, so workers run this interpreter."""
    from blender_addon import environment

    for variable in ("PHYROGEN_VENV", "VIRTUAL_ENV"):
        monkeypatch.delenv(variable, raising=False)
    monkeypatch.setattr(environment, "REPOSITORY", tmp_path / "extensions")
    monkeypatch.setenv("PYTHONPATH", "elsewhere")
    return environment


def test_workers_get_the_site_packages_added_at_run_time(no_environment, monkeypatch, tmp_path):
    added = tmp_path / "extensions" / ".local" / "lib" / "python3.11" / "site-packages"
    (added / "bundled_dependency").mkdir(parents=True)
    (added / "bundled_dependency" / "__init__.py").write_text("")
    monkeypatch.syspath_prepend(str(added))
    monkeypatch.setattr(no_environment, "WORKER_MODULES", ("bundled_dependency", *no_environment.WORKER_MODULES))
    no_environment.share_with_workers()
    assert os.environ["PYTHONPATH"].split(os.pathsep) == [str(added), "elsewhere"]


def test_workers_do_not_get_a_checkout_on_their_path(no_environment, monkeypatch):
    # A checkout holds a package named phyrogen, which would shadow a legacy add-on of that name.
    monkeypatch.syspath_prepend(str(REPOSITORY))
    no_environment.share_with_workers()
    assert os.environ["PYTHONPATH"] == "elsewhere"


# The fresh Blender's script: install the zip with the extensions API, press Generate and Validate.
FRESH_BLENDER_SCRIPT = r'''
import importlib.util, json, os, sys, traceback

zip_path, out, result_path = sys.argv[1:4]
modules = ("phyrogen", "phyrogen_core", "solver", "blender_addon", "ompl", "numba", "llvmlite", "tqdm")
result = {"importable_before": [m for m in modules if importlib.util.find_spec(m) is not None],
          "sys_path": sys.path}
try:
    import bpy

    result["blender"] = bpy.app.version_string
    bpy.ops.wm.read_factory_settings(use_empty=True)
    result["install"] = sorted(bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True))
    settings = bpy.context.scene.phyrogen
    settings.generator = "simple_slider"
    settings.seed = 2
    settings.output = out
    result["generate"] = sorted(bpy.ops.phyrogen.generate())
    result["validate"] = sorted(bpy.ops.phyrogen.validate())
    folder = os.path.join(out, "simple_slider", "simple_slider_2")
    with open(os.path.join(folder, "puzzle.json"), "rb") as generated:
        result["generated_metadata"] = generated.read().decode()
    result["replan"] = sorted(bpy.ops.phyrogen.replan())  # OMPL in a worker of Blender's own Python
    result["objects"] = sorted(o.name for o in bpy.data.objects)
    result["origins"] = {m: getattr(importlib.util.find_spec(m), "origin", None) for m in modules}
    result["pythonpath"] = os.environ.get("PYTHONPATH", "")
    # bpy 4.5 hangs at interpreter exit while add-on classes are still registered.
    bpy.ops.preferences.addon_disable(module="bl_ext.user_default.phyrogen")
except Exception:
    result["error"] = traceback.format_exc()
with open(result_path, "w") as f:
    json.dump(result, f)
'''


def _requirement_closure(name: str) -> list[metadata.Distribution]:
    """``name``'s distribution and those it requires (without extras), as installed here."""
    found: dict[str, metadata.Distribution] = {}
    pending = [name]
    while pending:
        wanted = re.split(r"[<>=!~ \[;(]", pending.pop(), maxsplit=1)[0].lower().replace("_", "-")
        if wanted in found:
            continue
        distribution = metadata.distribution(wanted)
        found[wanted] = distribution
        pending += [r for r in (distribution.requires or []) if "extra ==" not in r]
    return list(found.values())


def fresh_blender_python(root: Path) -> Path:
    """A new virtual environment that holds the bpy wheel and what bpy requires, nothing else; its python."""
    venv.create(root, with_pip=False, symlinks=True)
    (site_packages,) = root.glob("lib/python*/site-packages")
    for distribution in _requirement_closure("bpy"):
        tops = {Path(str(f)).parts[0] for f in distribution.files or () if not str(f).startswith("..")}
        for top in sorted(tops):
            source = Path(str(distribution.locate_file(top)))
            if source.exists() and not (site_packages / top).exists():
                (site_packages / top).symlink_to(source)
    return root / "bin" / "python"


def run_fresh_blender(python: Path, script: str, arguments: list[str], tmp_path: Path) -> dict:
    """Run ``script`` in ``python`` with an empty Blender user folder, an empty working folder and no
    PYTHONPATH, PHYROGEN_VENV or VIRTUAL_ENV; the JSON it writes to the path given as its last argument."""
    home, work, result_path = tmp_path / "home", tmp_path / "cwd", tmp_path / "result.json"
    work.mkdir()
    script_path = tmp_path / "fresh_blender.py"
    script_path.write_text(script, encoding="utf-8")
    environment = {k: v for k, v in os.environ.items()
                   if k not in ("PYTHONPATH", "PHYROGEN_VENV", "VIRTUAL_ENV", "PYTHONHOME")
                   and not k.startswith("BLENDER_")}
    environment.update(HOME=str(home), BLENDER_USER_RESOURCES=str(home / "resources"))
    run = subprocess.run([str(python), str(script_path), *arguments, str(result_path)],
                         capture_output=True, text=True, timeout=600, cwd=work, env=environment)
    assert result_path.is_file(), run.stdout[-3000:] + run.stderr[-3000:]
    result = json.loads(result_path.read_text())
    assert "error" not in result, result["error"] + run.stderr[-3000:]
    return result


def _build_zip(out: Path, *options: str) -> Path:
    with wheel_cache_lock():
        result = subprocess.run([sys.executable, str(BUILD_ADDON), "--out", str(out), *options],
                                capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return Path(result.stdout.strip())


@pytest.fixture(scope="module")
def bundled_zip(tmp_path_factory):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    return _build_zip(tmp_path_factory.mktemp("dist"))


@pytest.mark.blender
def test_zip_bundles_the_wheels_its_manifest_lists(bundled_zip):
    build_addon = _build_addon_module()
    archive = zipfile.ZipFile(bundled_zip)
    manifest = tomllib.loads(archive.read("blender_manifest.toml").decode())
    bundled = sorted(n for n in archive.namelist() if n.startswith("wheels/"))
    assert sorted(w.removeprefix("./") for w in manifest["wheels"]) == bundled
    names = {build_addon.distribution_name(Path(n)) for n in bundled}
    assert names == {*build_addon.BUNDLED, "llvmlite", "phyrogen"}
    assert manifest["platforms"] == ["linux-x64"]
    # PhyRoGen's own wheel holds every package Generate runs, and no test or script.
    (own,) = [n for n in bundled if build_addon.distribution_name(Path(n)) == "phyrogen"]
    with zipfile.ZipFile(archive.open(own)) as wheel:
        tops = {n.split("/")[0] for n in wheel.namelist() if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"phyrogen", "phyrogen_core", "solver", "blender_addon", "manipulation"}


@pytest.mark.blender
@pytest.mark.slow
def test_fresh_blender_with_only_the_zip_generates_and_replans(bundled_zip, tmp_path):
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import verify_certificate

    python = fresh_blender_python(tmp_path / "blender-python")
    home, out = tmp_path / "home", tmp_path / "out"
    result = run_fresh_blender(python, FRESH_BLENDER_SCRIPT, [str(bundled_zip), str(out)], tmp_path)
    assert result["importable_before"] == []  # nothing of PhyRoGen's, before the zip is installed
    assert result["blender"].startswith("4.5")
    assert result["install"] == ["FINISHED"]
    assert result["generate"] == ["FINISHED"] and result["validate"] == ["FINISHED"]
    assert result["replan"] == ["FINISHED"], result
    assert {"base_link", "obj_00", "obj_01"} <= set(result["objects"])
    # PhyRoGen and its dependencies come from the wheels the extension installed, for Blender's
    # process and (on PYTHONPATH) for the generation worker that Generate started.
    extensions = home / "resources" / "extensions"
    for module, origin in result["origins"].items():
        assert origin is not None and Path(origin).is_relative_to(extensions), (module, origin)
    assert all(Path(p).is_relative_to(extensions) for p in result["pythonpath"].split(os.pathsep))

    folder = out / "simple_slider" / "simple_slider_2"
    assert (folder / "urdf" / "simple_slider_2.urdf").is_file() and (folder / "srdf" / "simple_slider_2.srdf").is_file()
    loaded = read_puzzle_dir(folder)  # strictly: metadata agrees with the URDF
    assert len(loaded.certificate) >= 2 and loaded.record.provenance.replanned is not None
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal) == []
    # The same puzzle as PhyRoGen's own environment makes.
    reference = tmp_path / "reference"
    subprocess.run([sys.executable, "-m", "phyrogen", "generate", "--generator", "simple_slider", "--seeds", "2",
                    "--out", str(reference), "--quiet"], check=True, capture_output=True, cwd=REPOSITORY)
    made = reference / "simple_slider" / "simple_slider_2"
    for name in ("urdf/simple_slider_2.urdf", "srdf/simple_slider_2.srdf"):
        assert (folder / name).read_bytes() == (made / name).read_bytes(), name
    assert result["generated_metadata"] == (made / "puzzle.json").read_text()  # as generated, before Re-plan


THIN_ZIP_SCRIPT = r'''
import json, sys, traceback

zip_path, result_path = sys.argv[1:3]
result = {}
try:
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    result["install"] = sorted(bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True))
    module = sys.modules["bl_ext.user_default.phyrogen"]
    result["panels"] = sorted(n for n in dir(bpy.types) if n.startswith("PHYROGEN_"))
    missing = module.missing_dependencies
    result["lines"] = missing.panel_lines(missing._message)
    bpy.ops.preferences.addon_disable(module="bl_ext.user_default.phyrogen")
    result["panels_after_disable"] = sorted(n for n in dir(bpy.types) if n.startswith("PHYROGEN_"))
except Exception:
    result["error"] = traceback.format_exc()
with open(result_path, "w") as f:
    json.dump(result, f)
'''


@pytest.mark.blender
@pytest.mark.slow
def test_without_the_wheels_the_panel_says_what_to_do(tmp_path):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    thin = _build_zip(tmp_path / "dist", "--no-wheels")
    assert not [n for n in zipfile.ZipFile(thin).namelist() if n.endswith(".whl")]
    python = fresh_blender_python(tmp_path / "blender-python")
    result = run_fresh_blender(python, THIN_ZIP_SCRIPT, [str(thin)], tmp_path)
    assert result["install"] == ["FINISHED"]
    # The add-on enables, and its tab, in place of the generator's, names what is missing and the ways out.
    assert result["panels"] == ["PHYROGEN_PT_missing_dependencies"]
    text = " ".join(result["lines"])
    assert result["lines"][0] == "PhyRoGen cannot generate here:"
    assert "No module named" in text and "scripts/build_addon.py" in text and "PHYROGEN_VENV" in text
    assert all(len(line) <= 48 for line in result["lines"][1:])
    assert result["panels_after_disable"] == []
