"""The Python glue around the planners gives the same numbers by the faster route: chain_path's numpy
expansion, OMPL states read by one raw copy, the compiled kernels called without numba's dispatch, and
shape tables and kept pairs shared by the models of chains of the same shapes."""

from __future__ import annotations

import dataclasses
import struct

import numpy as np
import pytest

import solver.collision.model as model_module
import solver.collision.shape_table as table_module
from phyrogen_core.geometry import Pose
from phyrogen_core.objects import build_chain
from phyrogen_core.puzzle import Goal
from solver.collision.kernels import motion_collides_packed, state_valid_packed
from solver.collision.model import CollisionModel
from solver.collision.shape_table import shape_table
from solver.pipelines.generation import generate_here
from solver.planning.problem import chain_path, problem_for_chain


def _reference_chain_path(problem, path):
    """chain_path as it was: one float() per state and joint."""
    model = problem.model
    column = {n: i for i, n in enumerate(model.joint_order)}
    return tuple(tuple(float(state[column[n]]) if n in column else float(model.locked[n])
                       for n in model.chain.joint_order) for state in path)


def _bits(path) -> list:
    return [[struct.pack("d", v) for v in state] for state in path]


def _objects(seed: int):
    return generate_here("continuous_space", seed, None).objects


def test_chain_path_gives_the_same_floats():
    objects = _objects(9971001)
    chain = build_chain(objects)
    target = objects[0].name
    goal = Goal(target, {chain.joint_order[0]: 0.1}, 0.01)
    fixed = [o.name for o in objects[1:3] if o.name != target]
    problem = problem_for_chain(chain, goal, fixed=fixed)
    assert problem.model.locked, "the case must hold locked joints"
    rng = np.random.default_rng(5)
    d = len(problem.model.joint_order)
    paths = [rng.uniform(-2, 2, (n, d)) for n in (1, 2, 37)]
    paths.append(tuple(tuple(row) for row in paths[-1].tolist()))  # tuples of Python floats
    paths.append([np.array([-0.0] * d), np.array([5e-324] * d)])  # signed zero and a subnormal
    paths.append([[1] * d, [2] * d])  # integers
    for path in paths:
        expected = _reference_chain_path(problem, path)
        found = chain_path(problem, path)
        assert found == expected and _bits(found) == _bits(expected)
        assert all(type(v) is float for state in found for v in state)
    assert chain_path(problem, ()) == () == _reference_chain_path(problem, ())
    assert chain_path(problem, iter(paths[1])) == _reference_chain_path(problem, paths[1])  # any iterable
    # Negative control: the comparison sees a one-ulp change of one value.
    path = paths[2].copy()
    moved = path.copy()
    moved[5, 0] = np.nextafter(moved[5, 0], np.inf)
    assert _bits(chain_path(problem, moved)) != _bits(_reference_chain_path(problem, path))


def test_raw_state_reads_match_indexing():
    from ompl import base as ob

    from solver.planning.ompl_setup import _RawStates

    for dimension in (1, 4, 13):
        space = ob.RealVectorStateSpace(dimension)
        raw = _RawStates.of(space, dimension, 2, space.allocState())
        assert raw is not None
        state = space.allocState()
        values = np.random.default_rng(dimension).uniform(-1e3, 1e3, dimension)
        values[0] = -0.0
        for i, v in enumerate(values.tolist()):
            state[i] = v
        raw.read(raw.capsules[1], state)
        assert _bits([raw.rows[1].tolist()]) == _bits([[state[i] for i in range(dimension)]])
    # Negative control: a space whose states are not `dimension` doubles is refused (read joint by joint).
    space = ob.RealVectorStateSpace(3)
    assert _RawStates.of(space, 4, 2, space.allocState()) is None


def test_compiled_entry_answers_as_the_dispatcher():
    from solver.planning.ompl_setup import _compiled

    chain = build_chain(_objects(9971002))
    model = CollisionModel(chain)
    d = len(model.joint_order)
    ints, floats, columns = model.packed
    steps = model.motion_steps(0.02)
    a, b = np.zeros(d), np.zeros(d)
    motion_collides_packed(a, b, steps, ints, floats, columns)  # compiled (or loaded) for these types
    state_valid_packed(a, ints, floats)
    motion = _compiled(motion_collides_packed, (a, b, steps, ints, floats, columns))
    valid = _compiled(state_valid_packed, (a, ints, floats))
    assert motion is not motion_collides_packed and valid is not state_valid_packed
    rng = np.random.default_rng(7)
    lower, upper = chain.lower_limits, chain.upper_limits
    answers = set()
    for _ in range(300):
        a[:] = rng.uniform(lower, upper)
        b[:] = rng.uniform(lower, upper)
        expected = motion_collides_packed(a, b, steps, ints, floats, columns)
        assert motion(a, b, steps, ints, floats, columns) == expected
        assert valid(a, ints, floats) == state_valid_packed(a, ints, floats)
        answers.add(bool(expected))
    assert answers == {True, False}  # both verdicts were compared
    # Negative control: types never compiled fall back to the dispatcher itself.
    assert _compiled(state_valid_packed, (a.astype(np.float32), ints, floats)) is state_valid_packed


def _state(model: CollisionModel) -> list:
    arrays = [model._kin_int, model._kin_float, *model._arguments[3:11], model._pair_columns, model._packed_int,
              model._packed_float, model.joint_reach(), model._shape_rho]
    return [[(a.dtype.str, a.shape, a.tobytes()) for a in arrays], model._pair_objects, model._pair_names,
            model.joint_order]


def _unshared(chain, locked, tolerance, monkeypatch) -> CollisionModel:
    """The model with no table or kept pairs shared (each computed for this model alone)."""
    with monkeypatch.context() as patch:
        patch.setattr(model_module, "shared_shape_table", shape_table)
        patch.setattr(model_module, "_chain_parts", lambda chain: None)
        patch.setattr(model_module.ShapeTable, "kept",
                      lambda self, moving, tol: np.ascontiguousarray(self.pairs[self.kept_pairs(moving, tol)]))
        return CollisionModel(chain, locked, tolerance)


@pytest.mark.parametrize("seed", [9971003, 9971004])
def test_chains_of_the_same_shapes_share_tables_and_make_the_same_models(seed, monkeypatch):
    objects = list(_objects(seed))
    first = build_chain(objects)
    # Another candidate's chain: the same shapes, the last object elsewhere (a new chain, new objects).
    moved = objects[-1]
    x, y, z = moved.pose.xyz
    objects[-1] = dataclasses.replace(moved, pose=Pose.planar(x + 0.123, y - 0.05, z, moved.pose.yaw))
    second = build_chain(objects)
    assert second is not first
    table_module._TABLES.clear()
    model_module._PARTS.clear()
    joints = second.joint_order
    # At 10 m no pair's z extents overlap enough: a kept-pairs cache that ignored the tolerance would hand
    # over the 1e-6 model's pairs.
    questions = [({}, 1e-6), ({}, 0.04), ({}, 10.0), ({joints[0]: 0.0}, 1e-6),
                 ({j: 0.0 for j in joints[-2:]}, 0.02)]
    for chain in (first, second):
        for locked, tolerance in questions:
            assert _state(CollisionModel(chain, locked, tolerance)) == _state(
                _unshared(chain, locked, tolerance, monkeypatch)), (locked, tolerance)
    assert model_module._chain_parts(first).table is model_module._chain_parts(second).table
    # Negative control: the comparison tells the two chains' models apart (the moved object's pose).
    assert _state(CollisionModel(first)) != _state(CollisionModel(second))
