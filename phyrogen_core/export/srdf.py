"""SRDF text of a chain: what a motion planner needs beyond the URDF.

One planning group per puzzle object holds that object's non-fixed joints
(the chain's factors), so a planner can move one object at a time; and the
parent and child links of every joint are allowed to touch (``Adjacent``),
as hinges and stacked helper links always do.
"""

from __future__ import annotations

from ..chain import KinematicChain
from .formatting import attribute


def chain_to_srdf(chain: KinematicChain) -> str:
    """The SRDF text of ``chain``; groups sorted by object name, pairs by joint name."""
    groups: dict[str, list[str]] = {}
    for joint_name in chain.joint_order:
        object_name = chain.object_of_joint(joint_name)
        if not object_name:
            child = chain.joint(joint_name).child
            raise ValueError(
                f"joint {joint_name!r} moves link {child!r}, which has no object_name; "
                "every moving link needs one to form an SRDF group"
            )
        groups.setdefault(object_name, []).append(joint_name)
    lines = ['<?xml version="1.0"?>', f"<robot name={attribute(chain.name)}>"]
    for object_name in sorted(groups):
        lines.append(f"  <group name={attribute(object_name)}>")
        lines += [f"    <joint name={attribute(j)}/>" for j in groups[object_name]]
        lines.append("  </group>")
    # Every link has one parent joint, so each (parent, child) pair appears once.
    for joint in sorted(chain.joints, key=lambda j: j.name):
        lines.append(f"  <disable_collisions link1={attribute(joint.parent)} "
                     f'link2={attribute(joint.child)} reason="Adjacent"/>')
    lines.append("</robot>")
    return "\n".join(lines) + "\n"
