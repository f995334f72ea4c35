"""The stated bounds on every size a reader takes from a file, in one place.

The command line bounds its own numbers (``--workers``, ``--budget``, a
generator's parameters); these bound what a file says: how many links,
joints and shapes a URDF holds, how many corners a prism mesh or triangles
an imported mesh has, how many states a certificate lists. Every stage's
cost grows with them (the collision model with the pairs of shapes, the
MJCF writer and the robot with the states), and a file far past them made
one command run for hours or ask for hundreds of GiB. Each bound is many
times the largest the generators make (``docs/generators.md#feasible-sizes``
lists both), so no generated or imported puzzle comes near it, and is
checked before the work that grows with it, as bad input naming the file
and the bound. The size of a file itself is bounded by
:data:`phyrogen_core.folder.MAX_FILE_BYTES`.
"""

from __future__ import annotations

from dataclasses import dataclass

MAX_LINKS = 1_000
"""Links of one URDF (the base, helper and goal links included). The paper's puzzles have at most 40
(Rooms), Move N Times 22 at n = 4 and about 5 n + 2 at n (some 100 at its largest, n = 20); a URDF
of 30,000 static boxes took ``check`` 296 CPU s."""
MAX_JOINTS = MAX_LINKS
"""Joints of one URDF: a tree has one joint fewer than links, so more can only be an error."""
MAX_SHAPES = 2_000
"""``<visual>`` and ``<collision>`` elements of one URDF together (a prism counts one per convex piece);
the paper's puzzles have at most 89 (Rooms)."""
MAX_PRISM_VERTICES = 512
"""Vertices of one convex prism piece's OBJ mesh in a puzzle folder (two per corner: 256 corners).
The generators' slot discs have pieces of at most 19 corners; a 200,000-gon made ``replan`` ask
for 298 GiB."""
MAX_MESH_TRIANGLES = 200_000
"""Triangles of one mesh an imported URDF names (STL or OBJ); a 16 MiB binary STL holds at most
335,000."""
MAX_CERTIFICATE_STATES = 20_000
"""States of a certificate. The paper's puzzles' clean certificates hold at most 45 (Move N Times 4);
one of 200,000 states ran ``manipulate`` past 696 CPU s and ``render`` past 806 CPU s."""


@dataclass(frozen=True)
class SizeBound:
    """One stated bound: what is counted, and the most that is accepted."""

    what: str
    most: int

    def problem(self, count: int) -> str | None:
        """Why ``count`` is refused, in words that name the bound, or None when it is accepted."""
        if count <= self.most:
            return None
        return (f"holds {count} {self.what}, more than the {self.most} accepted (stated bounds: "
                "docs/generators.md#feasible-sizes)")


LINKS = SizeBound("links", MAX_LINKS)
JOINTS = SizeBound("joints", MAX_JOINTS)
SHAPES = SizeBound("shapes (<visual> and <collision> elements)", MAX_SHAPES)
PRISM_VERTICES = SizeBound("vertices", MAX_PRISM_VERTICES)
MESH_TRIANGLES = SizeBound("triangles", MAX_MESH_TRIANGLES)
CERTIFICATE_STATES = SizeBound("states", MAX_CERTIFICATE_STATES)


def urdf_size_problem(robot: object) -> str | None:
    """Why the parsed URDF ``robot`` (an ``xml.etree.ElementTree.Element``) is too large, or None.

    Counted on the element tree before any link or shape is built, so a refused file costs its
    parse only."""
    links = robot.findall("link")  # type: ignore[attr-defined]
    counts = ((LINKS, len(links)), (JOINTS, len(robot.findall("joint"))),  # type: ignore[attr-defined]
              (SHAPES, sum(len(link.findall("visual")) + len(link.findall("collision")) for link in links)))
    for bound, count in counts:
        problem = bound.problem(count)
        if problem is not None:
            return problem
    return None
