"""Collision models of one chain share what no locked joint and no tolerance changes (solver/collision/model.py's
_ChainParts): each must be the model built from scratch, array for array."""

from __future__ import annotations

import pytest

import solver.collision.model as model_module
from phyrogen_core.objects import build_chain
from solver.collision.model import CollisionModel
from solver.pipelines.generation import generate_here


def _state(model: CollisionModel) -> list:
    """Everything a model's queries read, in a comparable form."""
    arrays = [model._kin_int, model._kin_float, *model._arguments[3:11], model._pair_columns, model._packed_int,
              model._packed_float, model.joint_reach(), model._shape_rho]
    outlines = [(o.link, o.obj, o.radius, o.z_low, o.z_high, None if o.vertices is None else o.vertices.tobytes())
                for o in model._outlines]
    rest = {name: matrix.tobytes() for name, matrix in model._rest.items()}
    return [[(a.dtype.str, a.shape, a.tobytes()) for a in arrays], model._pair_objects, model._pair_names,
            outlines, rest, model.joint_order]


def _fresh(chain, locked, tolerance) -> CollisionModel:
    """The model built from scratch: no parts shared (the path of a chain whose parts are not kept)."""
    keep = model_module._chain_parts
    model_module._chain_parts = lambda chain: None
    try:
        return CollisionModel(chain, locked, tolerance)
    finally:
        model_module._chain_parts = keep


@pytest.mark.parametrize("generator, seed", [("rooms", 9960101), ("lockbox_random", 9960102),
                                             ("continuous_space", 9960103)])
def test_shared_parts_make_the_same_models(generator, seed):
    chain = build_chain(generate_here(generator, seed, None).objects)
    joints = chain.joint_order
    revolute = [j for j in joints if chain.joint(j).type.value == "revolute"]
    questions = [({}, 1e-6), ({}, 0.02), ({joints[0]: 0.0}, 1e-6), ({j: 0.0 for j in joints[1:]}, 0.08),
                 ({joints[-1]: -0.0}, 1e-6), ({joints[0]: 0.37}, 1e-6), ({joints[-1]: -1.1}, 0.02)]
    questions += [({j: 0.5}, 1e-6) for j in revolute[:2]]
    for locked, tolerance in questions:
        expected = _state(_fresh(chain, locked, tolerance))
        model_module._PARTS.clear()
        CollisionModel(chain)  # the parts, kept from an unlocked model
        shared = CollisionModel(chain, locked, tolerance)
        assert _state(shared) == expected, (locked, tolerance)
    # Negative control: the comparison tells models apart (another locked value, another tolerance).
    assert _state(_fresh(chain, {joints[0]: 0.37}, 1e-6)) != _state(_fresh(chain, {joints[0]: 0.0}, 1e-6))
    assert _state(_fresh(chain, {}, 0.02)) != _state(_fresh(chain, {}, 1e-6))
