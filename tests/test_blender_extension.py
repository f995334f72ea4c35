"""The self-contained zips: each bundles what every panel button runs, and a fresh Blender with nothing but
the zip installed presses Generate, Validate, Re-plan, Benchmark and Manipulate to completion.

Two zips (``scripts/build_addon.py``): the extension for Blender 4.2+, installed in the bpy 4.5 wheel, and
the legacy add-on for Blender 3.x, installed in Debian's Blender 3.4.1 through Preferences > Add-ons >
Install. "Fresh" means an empty Blender user folder (``BLENDER_USER_*``), an empty working folder, no
PYTHONPATH, PHYROGEN_VENV or VIRTUAL_ENV; for the wheel, also a Python that holds nothing else: a new
virtual environment whose site-packages links bpy and the distributions bpy requires (what a Blender
binary ships: numpy, requests, zstandard, Cython). PhyRoGen and its dependencies can come only from the
zip (``tests/blender_install_script.py`` runs in that Blender).
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
from blender_support import tool, wheel_cache_lock

REPOSITORY = Path(__file__).resolve().parent.parent
BUILD_ADDON = REPOSITORY / "scripts" / "build_addon.py"
INSTALL_SCRIPT = REPOSITORY / "tests" / "blender_install_script.py"
BLENDER = tool("blender")


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


def _build_zip(out: Path, *options: str) -> list[Path]:
    with wheel_cache_lock():
        result = subprocess.run([sys.executable, str(BUILD_ADDON), "--out", str(out), *options],
                                capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return [Path(line) for line in result.stdout.split()]


@pytest.fixture(scope="module")
def zips(tmp_path_factory):
    """The extension zip and the legacy add-on zip, built once for the module."""
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    extension, legacy = _build_zip(tmp_path_factory.mktemp("dist"))
    return extension, legacy


@pytest.fixture(scope="module")
def bundled_zip(zips):
    return zips[0]


@pytest.mark.blender
def test_zip_bundles_the_wheels_its_manifest_lists(bundled_zip):
    build_addon = _build_addon_module()
    archive = zipfile.ZipFile(bundled_zip)
    manifest = tomllib.loads(archive.read("blender_manifest.toml").decode())
    bundled = sorted(n for n in archive.namelist() if n.startswith("wheels/"))
    assert sorted(w.removeprefix("./") for w in manifest["wheels"]) == bundled
    names = {build_addon.distribution_name(Path(n)) for n in bundled}
    assert {*build_addon.BUNDLED, "llvmlite", "phyrogen"} <= names  # and what they require
    assert not names & set(build_addon.PROVIDED_BY_BLENDER)  # Blender's own numpy stays Blender's
    assert manifest["platforms"] == ["linux-x64"]
    # PhyRoGen's own wheel holds every package Generate runs, and no test or script.
    (own,) = [n for n in bundled if build_addon.distribution_name(Path(n)) == "phyrogen"]
    with zipfile.ZipFile(archive.open(own)) as wheel:
        tops = {n.split("/")[0] for n in wheel.namelist() if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"phyrogen", "phyrogen_core", "solver", "blender_addon", "manipulation"}


def check_installed_jobs(result: dict, out: Path, installed: Path) -> None:
    """What every fresh-install test asserts of ``tests/blender_install_script.py``'s result: all five
    buttons finished, from the zip's files, and their outputs hold."""
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import verify_certificate

    assert result["importable_before"] == []  # nothing of PhyRoGen's, before the zip is installed
    assert result["panels"] == ["PHYROGEN_PT_panel"]
    assert result["missing"] == {"benchmark": [], "manipulate": []}  # every button shown
    for job in ("generate", "validate", "replan", "benchmark", "manipulate", "generate_again"):
        assert result[job] == ["FINISHED"], (job, result.get(f"{job}_message"))
    # PhyRoGen and its dependencies come from the installed zip, for Blender's process and (on
    # PYTHONPATH) for the workers that the jobs started.
    for module, origin in result["origins"].items():
        assert origin is not None and Path(origin).is_relative_to(installed), (module, origin)
    assert all(Path(p).is_relative_to(installed) for p in result["pythonpath"].split(os.pathsep))
    # numba's compiled kernels: none before the first job, kept for the next ones in the user's folder.
    assert not result["cached_before"] and result["first_run_note"].startswith("compiling collision kernels")
    assert result["cached_after"] and result["first_run_note_after"] == ""
    package = Path(result["module_file"]).parent  # an installed add-on must not write into its own folder
    assert not Path(result["numba_cache"]).is_relative_to(package)
    assert not any(Path(result["numba_cache"]).is_relative_to(p) for p in result["pythonpath"].split(os.pathsep))

    folder = out / "simple_slider" / "simple_slider_2"
    loaded = read_puzzle_dir(folder)  # strictly: metadata agrees with the URDF
    assert len(loaded.certificate) >= 2 and loaded.record.provenance.replanned is not None
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal) == []
    assert f"States\t{len(loaded.certificate)}" in result["replan_table"]
    benchmark = json.loads((out / "benchmark" / "simple_slider_2" / "summary.json").read_text())
    assert [row.split("\t")[:2] for row in result["benchmark_table"][1:]] == [
        [c["planner"].removesuffix(" (ours)"), f"{c['successes']}/{c['runs']}"] for c in benchmark["cells"]]
    report = json.loads((out / "manipulation" / "simple_slider_2" / "report.json").read_text())
    assert report["success"], report
    assert (out / "manipulation" / "simple_slider_2" / "simple_slider_2.mp4").stat().st_size > 0
    assert len(list((out / "manipulation" / "simple_slider_2" / "frames").glob("frame_*.png"))) == 4
    assert (out / "simple_slider" / "simple_slider_3" / "puzzle.json").is_file()


def _fresh_environment(home: Path) -> dict[str, str]:
    environment = {k: v for k, v in os.environ.items()
                   if k not in ("PYTHONPATH", "PHYROGEN_VENV", "VIRTUAL_ENV", "PYTHONHOME", "NUMBA_CACHE_DIR")
                   and not k.startswith("BLENDER_")}
    environment.update(BLENDER_USER_RESOURCES=str(home / "resources"), BLENDER_USER_CONFIG=str(home / "config"),
                       BLENDER_USER_SCRIPTS=str(home / "scripts"))
    return environment


def _install_and_press(command: list[str], kind: str, zip_path: Path, tmp_path: Path) -> dict:
    home, work, out, result_path = tmp_path / "home", tmp_path / "cwd", tmp_path / "out", tmp_path / "result.json"
    work.mkdir()
    run = subprocess.run([*command, "--", kind, str(zip_path), str(out), str(result_path)],
                         capture_output=True, text=True, timeout=1800, cwd=work, env=_fresh_environment(home))
    assert result_path.is_file(), run.stdout[-3000:] + run.stderr[-3000:]
    result = json.loads(result_path.read_text())
    assert "error" not in result, result["error"] + run.stdout[-3000:] + run.stderr[-3000:]
    print(f"{kind}: Blender {result['blender']}, seconds {result['seconds']}, load {result['load']}")
    return result


@pytest.mark.blender
@pytest.mark.slow
def test_fresh_blender_4_with_only_the_extension_zip_runs_every_job(bundled_zip, tmp_path):
    python = fresh_blender_python(tmp_path / "blender-python")
    result = _install_and_press([str(python), str(INSTALL_SCRIPT)], "extension", bundled_zip, tmp_path)
    assert result["blender"].startswith("4.5") and result["install"] == ["FINISHED"]
    check_installed_jobs(result, tmp_path / "out", tmp_path / "home" / "resources" / "extensions")


@pytest.mark.blender
@pytest.mark.slow
@pytest.mark.skipif(BLENDER is None, reason="no blender binary here (apt-get install blender)")
def test_fresh_blender_3_with_only_the_legacy_zip_runs_every_job(zips, tmp_path):
    _, legacy = zips
    command = [BLENDER, "--background", "--factory-startup", "--python-exit-code", "1", "--python",
               str(INSTALL_SCRIPT)]
    result = _install_and_press(command, "legacy", legacy, tmp_path)
    assert result["blender"].startswith("3.") and result["install"] == ["FINISHED"]
    assert result["enable"] == ["FINISHED"]
    assert Path(result["module_file"]).is_relative_to(tmp_path / "home" / "scripts" / "addons" / "phyrogen_blender")
    check_installed_jobs(result, tmp_path / "out", tmp_path / "home" / "scripts" / "addons" / "phyrogen_blender")


@pytest.mark.blender
def test_legacy_zip_is_one_add_on_folder_with_bl_info(zips):
    _, legacy = zips
    names = zipfile.ZipFile(legacy).namelist()
    assert {n.split("/")[0] for n in names} == {"phyrogen_blender"}  # nothing scattered into addons/
    init = zipfile.ZipFile(legacy).read("phyrogen_blender/__init__.py").decode()
    assert "bl_info" in init and '"blender": (3, 4, 0)' in init
    tops = {n.split("/")[2].split(".")[0] for n in names if n.startswith("phyrogen_blender/site-packages/")}
    assert {"phyrogen", "phyrogen_core", "solver", "ompl", "numba", "numpy", "matplotlib", "pybullet",
            "imageio_ffmpeg"} <= tops


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
    (thin,) = _build_zip(tmp_path / "dist", "--no-wheels", "--kind", "extension")
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
