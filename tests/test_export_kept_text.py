"""Export text reused within a puzzle (a link's inertial lines by its collisions and mass, a prism piece's
OBJ text by its corners and height) and the goal marker's pose along the target's ancestors alone must be
exactly what is computed afresh. Fresh seeds 9960301-9960303."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from phyrogen_core.export import obj as obj_module
from phyrogen_core.export import urdf as urdf_module
from phyrogen_core.puzzle import _link_transform
from solver.pipelines.generation import generate_here


@pytest.mark.parametrize("generator, seed", [("rooms", 9960301), ("lockbox_random", 9960302),
                                             ("continuous_space", 9960303)])
def test_kept_text_and_the_goal_pose_are_computed_afresh(generator, seed):
    puzzle = generate_here(generator, seed, None)
    chain = puzzle.chain
    obj_module._prism_text.cache_clear()
    text, meshes = urdf_module.chain_to_urdf(chain)
    for link in chain.links:  # each link's inertial lines, computed for it alone, are in the text
        lines = "\n".join(urdf_module._inertial_lines(link))
        assert f'<link name="{link.name}">\n{lines}\n' in text
    for name, mesh in meshes.items():  # each piece's text afresh: the cache emptied before each
        obj_module._prism_text.cache_clear()
        link, kind, index, piece = name[:-4].rsplit("_", 3)
        geometry = getattr(chain.link(link), kind + "s")[int(index)]
        assert mesh == obj_module.prism_piece_obj(geometry.shape.pieces[int(piece)], geometry.shape.height, name[:-4])
    planning = puzzle.planning_chain
    values = {j: 0.0 for j in planning.joint_order} | dict(puzzle.goal.values)
    assert np.array_equal(_link_transform(planning, values, puzzle.goal.target),
                          planning.link_transforms(values)[puzzle.goal.target])
    # Negative controls: another mass, another goal value change what is compared.
    heavier = replace(chain.links[1], mass=chain.links[1].mass + 1.0)
    assert urdf_module._inertial_lines(heavier) != urdf_module._inertial_lines(chain.links[1])
    moved = dict(values) | {name: value + 0.1 for name, value in puzzle.goal.values.items()}
    assert not np.array_equal(_link_transform(planning, moved, puzzle.goal.target),
                              planning.link_transforms(values)[puzzle.goal.target])
