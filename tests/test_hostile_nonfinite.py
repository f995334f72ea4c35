"""Hostile input, class 1: a number read from a puzzle folder that is not a usable number.

Every number any reader takes from a puzzle folder (the URDF's attributes, the
OBJ meshes' vertices, every number of ``puzzle.json``, the benchmark's
solution file) must be finite; joint values and geometry must also lie within
``MAX_MAGNITUDE`` and in their domain (positive sizes, non-negative masses,
efforts and velocities, colours in [0, 1], lower limit at most upper).
Anything else is a :class:`PuzzleFormatError` naming the file and the field,
one line, and ``phyrogen check`` exits 2 with one line on stderr.

The cases are generated from a valid folder: every numeric attribute the URDF
writer produces (found by scanning the written file, so a new one is covered
without editing this test), every numeric field of ``puzzle.json`` (found by
walking the written file), each coordinate column of every mesh, every entry
of a solution path.

Generator parameters keep the same rule before any work: every float parameter
of every registered generator (found by asking the registry) must be finite
and every integer one fit 64 bits, whether it comes as ``--set`` text or in a
parameter dataclass; extreme finite values are refused up front, or generate.
"""

from __future__ import annotations

import dataclasses
import json
import math
import typing
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hostile_support import (
    assert_cli_rejects,
    copy_folder,
    edit_json,
    format_error,
    hostile_puzzle,
    mesh_files,
    numeric_attributes,
    replace_attribute,
    urdf_file,
    written,  # noqa: F401 (fixture)
)

from manipulation.solution import load_solution
from phyrogen.cli import main
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.export.reader import MAX_MAGNITUDE
from phyrogen_core.export.urdf import chain_to_urdf
from phyrogen_core.folder_layout import BEST_SOLUTION
from phyrogen_core.puzzle import Goal
from phyrogen_core.registry import ParameterError, all_generators, get_generator
from solver.pipelines.generation import generate_puzzle
from solver.planning.problem import verify_certificate

NON_FINITE = ("nan", "NaN", "inf", "-inf", "Infinity", "1e999", "-1e999")
"""Texts that Python's float() turns into NaN or an infinity."""
TOO_LARGE = ("1e300", "-2e6")

_URDF_TEXT = chain_to_urdf(hostile_puzzle().chain)[0]
URDF_ATTRIBUTES = sorted({(tag, name) for tag, name, _, _ in numeric_attributes(_URDF_TEXT)})


def test_the_valid_folder_reads_and_its_certificate_is_valid(written):  # noqa: F811
    loaded = read_puzzle_dir(written)
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal) == []


def test_the_scan_finds_every_kind_of_urdf_number():
    # The writer's numeric attributes; a new one is covered by the scan, this list only guards the scan.
    found = {name for _, name in URDF_ATTRIBUTES}
    assert found >= {"xyz", "rpy", "size", "radius", "length", "rgba", "value", "ixx", "iyy", "izz",
                     "lower", "upper", "effort", "velocity"}


def _urdf_cases(text: str, name: str, tag: str) -> Iterator[tuple[int, int, list[str]]]:
    """(occurrence index among the numeric attributes ``name``, component, the value's tokens) for every
    component of every attribute ``name`` of a ``<tag>`` element."""
    index = -1
    for element_tag, attribute, _, value in numeric_attributes(text):
        if attribute != name:
            continue
        index += 1
        if element_tag != tag:
            continue
        tokens = value.split()
        for component in range(len(tokens)):
            yield index, component, tokens


def _assert_each_urdf_value_refused(folder_written, tmp_path, tag: str, name: str, bad: str, fragment: str) -> None:
    """Put ``bad`` in each component of every ``<tag name=...>`` of the URDF in turn: each must be refused,
    naming the file and ``fragment``."""
    folder = copy_folder(folder_written, tmp_path / "copy")
    urdf = urdf_file(folder)
    original = urdf.read_text()
    cases = 0
    for index, component, tokens in _urdf_cases(original, name, tag):
        value = " ".join(bad if i == component else t for i, t in enumerate(tokens))
        urdf.write_text(replace_attribute(original, name, index, value))
        message = format_error(lambda: read_puzzle_dir(folder))
        assert str(urdf) in message and fragment in message, message
        cases += 1
    assert cases > 0


@pytest.mark.parametrize("bad", NON_FINITE + TOO_LARGE)
@pytest.mark.parametrize(("tag", "name"), URDF_ATTRIBUTES, ids=[f"{t}.{n}" for t, n in URDF_ATTRIBUTES])
def test_every_urdf_number_must_be_finite_and_bounded(written, tmp_path, tag, name, bad):  # noqa: F811
    _assert_each_urdf_value_refused(written, tmp_path, tag, name, bad, f"attribute {name}=")


@pytest.mark.parametrize(
    ("tag", "name", "bad", "fragment"),
    [
        ("box", "size", "0", "Box size must be three positive numbers"),
        ("box", "size", "-0.5", "Box size must be three positive numbers"),
        ("cylinder", "radius", "0", "Cylinder radius and length must be positive"),
        ("cylinder", "radius", "-0.1", "Cylinder radius and length must be positive"),
        ("cylinder", "length", "0", "Cylinder radius and length must be positive"),
        ("mass", "value", "-1", "attribute value="),
        ("limit", "effort", "-1", "attribute effort="),
        ("limit", "velocity", "-0.5", "attribute velocity="),
        ("color", "rgba", "1.5", "attribute rgba="),
        ("color", "rgba", "-0.25", "attribute rgba="),
        ("limit", "lower", "1e5", "exceeds upper"),
        ("limit", "upper", "-1e5", "exceeds upper"),
    ],
)
def test_urdf_numbers_outside_their_domain_are_rejected(written, tmp_path, tag, name, bad, fragment):  # noqa: F811
    _assert_each_urdf_value_refused(written, tmp_path, tag, name, bad, fragment)


@pytest.mark.parametrize("bad", NON_FINITE + TOO_LARGE)
@pytest.mark.parametrize("column", [1, 2, 3], ids=["x", "y", "z"])
def test_every_mesh_vertex_coordinate_must_be_finite_and_bounded(written, tmp_path, column, bad):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    meshes = mesh_files(folder)
    assert len(meshes) == 6
    for mesh in meshes:
        original = mesh.read_text()
        lines = original.splitlines()
        vertex_lines = [i for i, line in enumerate(lines) if line.startswith("v ")]
        for line_index in (vertex_lines[0], vertex_lines[-1]):
            fields = lines[line_index].split()
            fields[column] = bad
            mesh.write_text("\n".join(lines[:line_index] + [" ".join(fields)] + lines[line_index + 1:]) + "\n")
            message = format_error(lambda: read_puzzle_dir(folder))
            assert str(mesh) in message and f"line {line_index + 1}:" in message, message
        mesh.write_text(original)


def test_a_flat_mesh_is_rejected(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    for mesh in mesh_files(folder):
        original = mesh.read_text()
        flat = [" ".join(line.split()[:3] + ["0"]) if line.startswith("v ") else line for line in original.splitlines()]
        mesh.write_text("\n".join(flat) + "\n")
        message = format_error(lambda: read_puzzle_dir(folder))
        assert str(mesh) in message and "h > 0" in message
        mesh.write_text(original)


# -- puzzle.json -------------------------------------------------------------------------------
def _numeric_fields(data: Any, label: str = "") -> Iterator[tuple[str, tuple]]:
    """(label as the reader names it, key path) of every number in JSON ``data``."""
    if isinstance(data, dict):
        for key, value in data.items():
            for sub_label, path in _numeric_fields(value, f"{label}.{key}" if label else key):
                yield sub_label, (key,) + path
    elif isinstance(data, list):
        for index, value in enumerate(data):
            for sub_label, path in _numeric_fields(value, f"{label}[{index}]"):
                yield sub_label, (index,) + path
    elif isinstance(data, int | float) and not isinstance(data, bool):
        yield label, ()


def _set(data: Any, path: tuple, value: Any) -> None:
    for key in path[:-1]:
        data = data[key]
    data[path[-1]] = value


_MARK = "__bad_number__"
JSON_NON_FINITE = ("NaN", "Infinity", "-Infinity", "1e999", "-1e999", "1" + "0" * 400)
"""JSON texts that Python's parser accepts and turns into NaN, an infinity or an integer beyond any float."""


def test_the_walk_finds_every_kind_of_puzzle_json_number(written):  # noqa: F811
    labels = {label for label, _ in _numeric_fields(json.loads((written / "puzzle.json").read_text()))}
    for expected in ("format_version", "seed", "parameters.size", "parameters.nested.steps[1]",
                     "joint_limits.obj_02_yaw.upper", "start[4]", "goal.values.obj_00", "goal.tolerance",
                     "certificate[1][4]"):
        assert expected in labels


@pytest.mark.parametrize("bad", JSON_NON_FINITE)
def test_every_puzzle_json_number_must_be_finite(written, tmp_path, bad):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    path = folder / "puzzle.json"
    original = json.loads(path.read_text())
    fields = list(_numeric_fields(original))
    assert len(fields) >= 30
    for label, key_path in fields:
        data = json.loads(json.dumps(original))
        _set(data, key_path, _MARK)
        path.write_text(json.dumps(data).replace(f'"{_MARK}"', bad))
        message = format_error(lambda: read_puzzle_dir(folder))
        assert message.startswith(f"{path}: {label} is "), message


JOINT_VALUE_PREFIXES = ("joint_limits.", "start[", "goal.values.", "goal.tolerance", "certificate[")


@pytest.mark.parametrize("bad", [1e300, -1e300, 2 * MAX_MAGNITUDE])
def test_joint_values_of_puzzle_json_must_be_bounded(written, tmp_path, bad):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    path = folder / "puzzle.json"
    original = json.loads(path.read_text())
    fields = [(label, key_path) for label, key_path in _numeric_fields(original)
              if label.startswith(JOINT_VALUE_PREFIXES)]
    assert len(fields) >= 25
    for label, key_path in fields:
        data = json.loads(json.dumps(original))
        _set(data, key_path, bad)
        path.write_text(json.dumps(data))
        message = format_error(lambda: read_puzzle_dir(folder))
        assert message.startswith(f"{path}: {label}"), message


@pytest.mark.parametrize("bad", ['"0.5"', "true", "null", "[]"])
def test_joint_values_of_puzzle_json_must_be_numbers(written, tmp_path, bad):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    path = folder / "puzzle.json"
    original = json.loads(path.read_text())
    for label, key_path in _numeric_fields(original):
        if not label.startswith(JOINT_VALUE_PREFIXES):
            continue
        data = json.loads(json.dumps(original))
        _set(data, key_path, _MARK)
        path.write_text(json.dumps(data).replace(f'"{_MARK}"', bad))
        message = format_error(lambda: read_puzzle_dir(folder))
        assert str(path) in message and label.split("[")[0].split(".")[0] in message, message


# -- solution files ----------------------------------------------------------------------------
def _write_solution(folder: Path, text: str) -> Path:
    file = folder / BEST_SOLUTION
    file.parent.mkdir(exist_ok=True)
    file.write_text(text)
    return file


def _solution(loaded) -> dict:
    return {"format": "phyrogen-solution", "found_after": 0.5, "joint_order": list(loaded.joint_order),
            "path": [list(state) for state in loaded.certificate]}


def test_a_valid_solution_file_loads(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    loaded = read_puzzle_dir(folder)
    _write_solution(folder, json.dumps(_solution(loaded)))
    solution = load_solution(folder, loaded.joint_order, loaded.certificate)
    assert solution.path.tolist() == [list(s) for s in loaded.certificate]


@pytest.mark.parametrize("bad", JSON_NON_FINITE + ("1e300", '"nan"', "true", "null"))
def test_every_solution_number_must_be_finite_and_bounded(written, tmp_path, bad):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    loaded = read_puzzle_dir(folder)
    original = _solution(loaded)
    fields = list(_numeric_fields(original))
    assert len(fields) == 1 + 2 * len(loaded.joint_order)
    for label, key_path in fields:
        data = json.loads(json.dumps(original))
        _set(data, key_path, _MARK)
        file = _write_solution(folder, json.dumps(data).replace(f'"{_MARK}"', bad))
        if label == "found_after" and bad in ("1e300", '"nan"', "true", "null"):
            continue  # a field the executor does not read: only the finiteness rule applies
        message = format_error(lambda: load_solution(folder, loaded.joint_order, loaded.certificate))
        assert message.startswith(f"{file}: {label}"), message


# -- the certificate check and the command line -----------------------------------------------
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_verify_certificate_reports_non_finite_states_without_raising(written, bad):  # noqa: F811
    loaded = read_puzzle_dir(written)
    for row in range(len(loaded.certificate)):
        for column in range(len(loaded.joint_order)):
            path = np.array(loaded.certificate)
            path[row, column] = bad
            problems = verify_certificate(loaded.chain, path, loaded.goal)
            assert problems == [f"certificate state {row} holds a value that is not a finite number"]


@pytest.mark.parametrize("tolerance", [math.nan, math.inf, -1e-3, 0.0])
def test_verify_certificate_reports_a_goal_tolerance_that_is_not_a_positive_number(written, tolerance):  # noqa: F811
    loaded = read_puzzle_dir(written)
    goal = Goal(loaded.goal.target, loaded.goal.values, tolerance)
    problems = verify_certificate(loaded.chain, loaded.certificate, goal)
    assert any(p.startswith("goal: tolerance") for p in problems), problems


@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_verify_certificate_reports_a_non_finite_goal_value(written, value):  # noqa: F811
    loaded = read_puzzle_dir(written)
    goal = Goal(loaded.goal.target, {name: value for name in loaded.goal.values}, loaded.goal.tolerance)
    problems = verify_certificate(loaded.chain, loaded.certificate, goal)
    assert any("must be a finite number" in p for p in problems), problems


@pytest.mark.parametrize(
    ("corrupt", "fragments"),
    [
        (lambda f: urdf_file(f).write_text(replace_attribute(urdf_file(f).read_text(), "xyz", 0, "nan nan nan")),
         ("urdf", "attribute xyz=")),
        (lambda f: edit_json(f, lambda m: m["certificate"][1].__setitem__(0, math.inf)),
         ("puzzle.json", "certificate[1][0] is inf")),
        (lambda f: edit_json(f, lambda m: m["certificate"][1].__setitem__(2, math.nan)),
         ("puzzle.json", "certificate[1][2] is nan")),
        (lambda f: edit_json(f, lambda m: m["start"].__setitem__(0, math.nan)), ("puzzle.json", "start[0] is nan")),
        (lambda f: edit_json(f, lambda m: m["goal"].__setitem__("tolerance", math.inf)),
         ("puzzle.json", "goal.tolerance is inf")),
        (lambda f: edit_json(f, lambda m: m["parameters"].__setitem__("size", -math.inf)),
         ("puzzle.json", "parameters.size is -inf")),
        (lambda f: mesh_files(f)[0].write_text(mesh_files(f)[0].read_text().replace("v ", "v inf ", 1)),
         ("meshes", "line")),
    ],
)
def test_check_rejects_with_one_line_and_exit_2(written, tmp_path, corrupt, fragments):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    corrupt(folder)
    assert_cli_rejects(folder, *fragments)


def test_puzzle_format_error_is_a_value_error():
    assert issubclass(PuzzleFormatError, ValueError)


# -- generator parameters: refused before any work -------------------------------------------
def _parameters_of_type(kind: type) -> list[tuple[str, str]]:
    """(generator, parameter) for every registered generator's parameters of type ``kind``: a new
    generator's parameters are covered as soon as it is registered."""
    cases = []
    for name, spec in all_generators().items():
        hints = typing.get_type_hints(spec.params)
        cases += [(name, f.name) for f in dataclasses.fields(spec.params) if hints[f.name] is kind]
    return cases


FLOAT_PARAMETERS = _parameters_of_type(float)
INT_PARAMETERS = _parameters_of_type(int)
PARAMETER_TEXTS = ("nan", "NaN", "inf", "-inf", "Infinity", "1e999", "-1e999")
"""What ``--set key=value`` may carry that float() turns into NaN or an infinity."""


def _parameter_error(call) -> str:
    with pytest.raises(ParameterError) as caught:
        call()
    message = str(caught.value)
    assert "\n" not in message, message
    return message


def test_the_registry_has_float_and_int_parameters():
    # Guards the scan: the cases below are generated from it.
    assert ("rooms", "scaling") in FLOAT_PARAMETERS and ("continuous_space", "bar_length") in FLOAT_PARAMETERS
    assert ("move_n_times", "n") in INT_PARAMETERS


@pytest.mark.parametrize("bad", PARAMETER_TEXTS)
@pytest.mark.parametrize(("generator", "parameter"), FLOAT_PARAMETERS, ids=[f"{g}.{p}" for g, p in FLOAT_PARAMETERS])
def test_every_float_parameter_text_must_be_finite(generator, parameter, bad):
    message = _parameter_error(lambda: get_generator(generator).parse_params({parameter: bad}))
    assert f"generator {generator!r}" in message and repr(parameter) in message and bad in message


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize(("generator", "parameter"), FLOAT_PARAMETERS, ids=[f"{g}.{p}" for g, p in FLOAT_PARAMETERS])
def test_every_float_parameter_of_a_dataclass_must_be_finite(generator, parameter, bad):
    # The Python API and Job.params pass a parameter dataclass, which parse_params never sees.
    spec = get_generator(generator)
    params = dataclasses.replace(spec.default_params(), **{parameter: bad})
    message = _parameter_error(lambda: spec.check(1, params))
    assert f"generator {generator!r}" in message and repr(parameter) in message


@pytest.mark.parametrize("value", [1e308, -1e308, 1e20, 5e-324])
@pytest.mark.parametrize(("generator", "parameter"), FLOAT_PARAMETERS, ids=[f"{g}.{p}" for g, p in FLOAT_PARAMETERS])
def test_extreme_finite_floats_are_refused_up_front_or_generate(generator, parameter, value):
    spec = get_generator(generator)
    try:
        params = spec.parse_params({parameter: repr(value)})
        spec.check(1, params)
    except ParameterError as exc:
        message = str(exc)
        assert "\n" not in message and parameter in message, message
        return
    # Accepted: then it is a size that works, not an overflow or endless work inside a worker.
    assert generate_puzzle(generator, 1, params).certificate


@pytest.mark.parametrize("bad", [str(2**63), "1" + "0" * 400, "1e300", "nan", "inf", "2.5"])
@pytest.mark.parametrize(("generator", "parameter"), INT_PARAMETERS, ids=[f"{g}.{p}" for g, p in INT_PARAMETERS])
def test_every_int_parameter_text_must_be_a_bounded_integer(generator, parameter, bad):
    message = _parameter_error(lambda: get_generator(generator).parse_params({parameter: bad}))
    assert f"generator {generator!r}" in message and repr(parameter) in message


@pytest.mark.parametrize("bad", [2**63, -(2**64), math.nan, math.inf, 2.5, "3", True])
@pytest.mark.parametrize(("generator", "parameter"), INT_PARAMETERS, ids=[f"{g}.{p}" for g, p in INT_PARAMETERS])
def test_every_int_parameter_of_a_dataclass_must_be_a_bounded_integer(generator, parameter, bad):
    spec = get_generator(generator)
    params = dataclasses.replace(spec.default_params(), **{parameter: bad})
    message = _parameter_error(lambda: spec.check(1, params))
    assert f"generator {generator!r}" in message and repr(parameter) in message


@pytest.mark.parametrize(("generator", "assignment"), [
    ("rooms", "scaling=nan"), ("continuous_space", "bar_length=inf"), ("rooms", "wall_height=inf"),
    ("grid_world", "clearance=-inf"), ("lockbox_random", "max_radius=1e999"), ("simple_slider", "gap=NaN"),
    ("grid_world", "n_objects=1e300"),
])
def test_generate_refuses_a_non_finite_parameter_with_one_line(generator, assignment, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["generate", "--generator", generator, "--seeds", "1", "--set", assignment, "--out", str(out),
                 "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("phyrogen: error: "), err
    key, _, value = assignment.partition("=")
    assert generator in err and key in err and value in err, err
    assert not out.exists()
