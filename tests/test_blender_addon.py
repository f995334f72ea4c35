"""The add-on as an installed extension in the bpy wheel: panel, operators, build step."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from blender_support import FakeLayout, private_blender_home, wheel_cache_lock

private_blender_home()
bpy = pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")

from phyrogen_core.export import chain_to_urdf, read_puzzle_dir  # noqa: E402
from phyrogen_core.registry import all_generators  # noqa: E402

REPOSITORY = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def extension_zip(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    with wheel_cache_lock():
        # The thin extension: this process has PhyRoGen's environment (the bundled zips are tested in
        # tests/test_blender_extension.py, from fresh Blenders).
        result = subprocess.run([sys.executable, str(REPOSITORY / "scripts" / "build_addon.py"), "--out", str(out),
                                 "--kind", "extension", "--no-wheels"], capture_output=True, text=True, check=True)
    return Path(result.stdout.strip())


@pytest.fixture(scope="module")
def installed(extension_zip):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    result = bpy.ops.extensions.package_install_files(filepath=str(extension_zip), repo="user_default",
                                                      enable_on_install=True)
    assert result == {"FINISHED"}
    module = sys.modules["bl_ext.user_default.phyrogen"]
    yield module
    # bpy 4.5 hangs at interpreter exit while add-on classes are still registered.
    bpy.ops.preferences.addon_disable(module="bl_ext.user_default.phyrogen")


def test_extension_zip_holds_manifest_and_package(extension_zip):
    import zipfile

    names = set(zipfile.ZipFile(extension_zip).namelist())
    assert {"blender_manifest.toml", "__init__.py", "ui.py", "scene.py"} <= names
    assert not [n for n in names if "__pycache__" in n]


def test_panel_shows_generator_seed_parameters_and_operators(installed):
    settings = bpy.context.scene.phyrogen
    for name, spec in all_generators().items():
        settings.generator = name
        log = []
        installed.ui.draw_panel(FakeLayout(log), settings)
        shown = [n for kind, n in log if kind == "prop"]
        assert shown[:2] == ["generator", "seed"]
        assert [f.name for f in installed.ui.editable_fields(spec.params)] == shown[2:-2]
        assert [n for kind, n in log if kind == "operator"] == [
            "phyrogen.generate", "phyrogen.replan", "phyrogen.benchmark", "phyrogen.manipulate",
            "phyrogen.validate", "phyrogen.export_urdf", "phyrogen.render"]


def test_export_with_phobos_is_offered_only_while_phobos_is_enabled(installed):
    log = []
    installed.ui.draw_panel(FakeLayout(log), bpy.context.scene.phyrogen, phobos=True)
    assert ("operator", "phyrogen.export_phobos") in log and ("prop", "phobos_output") in log
    # Phobos is not installed here: the panel leaves the button out (see above) and the operator is off.
    assert not installed.phobos.phobos_enabled()
    assert not bpy.ops.phyrogen.export_phobos.poll()


def test_generator_drop_down_is_fed_by_the_registry(installed):
    items = bpy.types.Scene.bl_rna.properties["phyrogen"].fixed_type.properties["generator"].enum_items
    assert [i.identifier for i in items] == list(all_generators())


@pytest.mark.slow
def test_operators_generate_validate_export_render(installed, tmp_path):
    settings = bpy.context.scene.phyrogen
    settings.generator = "simple_slider"
    settings.seed = 2
    settings.params_simple_slider.gap = 0.15
    settings.output = str(tmp_path)
    settings.engine = "CYCLES"  # Workbench would need EGL in this very process
    assert bpy.ops.phyrogen.generate() == {"FINISHED"}
    assert bpy.data.collections.get("simple_slider_2") is not None
    assert bpy.ops.phyrogen.validate() == {"FINISHED"}
    assert bpy.ops.phyrogen.export_urdf() == {"FINISHED"}
    folder = tmp_path / "simple_slider" / "simple_slider_2"
    loaded = read_puzzle_dir(folder)
    assert loaded.record.parameters["gap"] == 0.15
    assert (folder / "urdf" / "simple_slider_2.urdf").read_text() == chain_to_urdf(loaded.chain)[0]
    assert bpy.ops.phyrogen.render() == {"FINISHED"}
    assert sorted(p.name for p in (folder / "images").iterdir()) == [
        "simple_slider_2_00.png", "simple_slider_2_01.png", "simple_slider_2_02.png"]
    # Moving the target's blocker into its path breaks the certificate: Validate says so.
    bpy.data.objects["obj_01"].location.x += 0.3
    with pytest.raises(RuntimeError, match="INVALID"):
        bpy.ops.phyrogen.validate()


def test_bad_parameters_are_reported_not_raised(installed):
    settings = bpy.context.scene.phyrogen
    settings.generator = "simple_slider"
    settings.params_simple_slider.gap = 0.7
    with pytest.raises(RuntimeError, match="gap must lie in"):
        bpy.ops.phyrogen.generate()
    settings.params_simple_slider.gap = 0.1


def test_only_the_untouched_default_cube_is_removed(installed):
    """Generate removes Blender's factory cube, which hides a puzzle at the origin, and nothing of a user's."""
    remove = installed.ui.remove_untouched_default_cube

    def factory_scene():
        bpy.ops.wm.read_homefile(use_factory_startup=True)
        return bpy.context.scene

    scene = factory_scene()
    assert sorted(o.name for o in scene.objects) == ["Camera", "Cube", "Light"]
    assert remove(scene) and sorted(o.name for o in scene.objects) == ["Camera", "Light"]
    # Controls: a moved cube, an edited one, and the factory scene with a user's object beside it stay.
    scene = factory_scene()
    scene.objects["Cube"].location.z = 0.5
    assert not remove(scene) and "Cube" in scene.objects
    scene = factory_scene()
    scene.objects["Cube"].data.vertices[0].co.x = -1.5
    assert not remove(scene) and "Cube" in scene.objects
    scene = factory_scene()
    bpy.ops.object.empty_add()
    assert not remove(scene) and "Cube" in scene.objects
    bpy.ops.wm.read_homefile(use_empty=True)
