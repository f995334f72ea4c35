"""A kinematic chain as Blender objects, and a Blender scene read back as a chain.

Layout (the one Phobos 2.x reads): every link is an Armature object with one
bone, parented to its parent link and placed at the joint origin (the state
of all joints is zero); the joint is described on the child link; visuals and
collisions are mesh objects parented to their link; a small box mesh (as
Phobos makes them) carries the link's mass and inertia. Collisions and
inertials live in child collections hidden in every view layer and in
renders, so renders and the viewport show the visuals only.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import bpy
import numpy as np
from mathutils import Matrix

from phyrogen_core.chain import Geometry, Joint, KinematicChain, Link, Role, pose_matrix
from phyrogen_core.export.urdf import chain_to_urdf, color_name
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder, Pose

from . import annotations as keys
from .phobos import ensure_phobostype, phobostype

CYLINDER_SEGMENTS = 32
BONE_LENGTH = 0.2


@dataclass(frozen=True)
class PuzzleScene:
    """The Blender objects built for one chain."""

    collection: bpy.types.Collection
    links: dict[str, bpy.types.Object]


def urdf_digest(chain: KinematicChain) -> str:
    """A digest of the URDF ``chain`` exports to: the same digest, the same puzzle."""
    return hashlib.sha256(chain_to_urdf(chain)[0].encode("utf-8")).hexdigest()


# -- chain -> Blender --------------------------------------------------------
def build_chain(chain: KinematicChain, scene: bpy.types.Scene | None = None,
                metadata_json: str | None = None) -> PuzzleScene:
    """Build ``chain`` at its zero state in a new collection named after it, linked to ``scene``."""
    ensure_phobostype()
    scene = scene or bpy.context.scene
    collection = bpy.data.collections.new(chain.name)
    scene.collection.children.link(collection)
    collection[keys.PUZZLE_NAME] = chain.name
    if metadata_json is not None:
        collection[keys.METADATA] = metadata_json
        collection[keys.URDF_DIGEST] = urdf_digest(chain)
    hidden = {}
    for kind in ("collision", "inertial"):
        child = bpy.data.collections.new(f"{chain.name}.{kind}")
        child.hide_render = True
        collection.children.link(child)
        # Hidden per view layer, not disabled (Collection.hide_viewport): a disabled collection's
        # objects are not evaluated, so their matrix_world, which Phobos reads, would stay stale.
        for view_layer in scene.view_layers:
            view_layer.layer_collection.children[collection.name].children[child.name].hide_viewport = True
        hidden[kind] = child

    joint_index = {joint.name: i for i, joint in enumerate(chain.joints)}
    links: dict[str, bpy.types.Object] = {}
    link_position = {link.name: i for i, link in enumerate(chain.links)}
    for name in chain.links_in_tree_order:
        link = chain.link(name)
        joint = chain.parent_joint(name)
        obj = bpy.data.objects.new(name, bpy.data.armatures.new(name))
        collection.objects.link(obj)
        obj.phobostype = "link"
        obj[keys.LINK_NAME] = name
        obj[keys.LINK_INDEX] = link_position[name]
        obj[keys.ROLE] = link.role.value
        obj[keys.OBJECT] = link.object_name
        if joint is None:
            obj[keys.MODEL_NAME] = chain.name
        else:
            obj.parent = links[joint.parent]
            obj.matrix_basis = _matrix(pose_matrix(joint.origin))
            for key, value in keys.joint_properties(joint).items():
                obj[key] = value
            obj[keys.JOINT_INDEX] = joint_index[joint.name]
        links[name] = obj
        _build_inertial(link, obj, hidden["inertial"])
        for index, geometry in enumerate(link.visuals):
            _build_geometry(link.name, "visual", index, geometry, obj, collection)
        for index, geometry in enumerate(link.collisions):
            _build_geometry(link.name, "collision", index, geometry, obj, hidden["collision"])
    _add_bones(list(links.values()), [chain.parent_joint(n) for n in links])
    bpy.context.view_layer.update()
    return PuzzleScene(collection, links)


def _matrix(m: np.ndarray) -> Matrix:
    return Matrix([[float(v) for v in row] for row in m])


def _add_bones(objects: Sequence[bpy.types.Object], joints: Sequence[Joint | None]) -> None:
    """One bone per link armature, along the joint axis (Phobos 1.x reads the axis from it).

    Bones exist only in edit mode: all armatures enter it together, once.
    """
    view_layer = bpy.context.view_layer
    previous_active = view_layer.objects.active
    previous_selection = [o for o in view_layer.objects if o.select_get(view_layer=view_layer)]
    if bpy.context.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    for obj in previous_selection:
        obj.select_set(False, view_layer=view_layer)
    for obj in objects:
        obj.select_set(True, view_layer=view_layer)
    view_layer.objects.active = objects[0]
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        for obj, joint in zip(objects, joints, strict=True):
            bone = obj.data.edit_bones.new("link")
            axis = joint.axis if joint is not None else (0.0, 0.0, 1.0)
            bone.head = (0.0, 0.0, 0.0)
            bone.tail = tuple(BONE_LENGTH * a for a in axis)
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")
    for obj in objects:
        obj.select_set(False, view_layer=view_layer)
    for obj in previous_selection:
        obj.select_set(True, view_layer=view_layer)
    view_layer.objects.active = previous_active
    for obj in objects:
        obj.data.display_type = "STICK"


def _build_inertial(link: Link, parent: bpy.types.Object, collection: bpy.types.Collection) -> None:
    centre, inertia = keys.inertial_values(link)
    # A small box mesh, as Phobos makes its own inertials: Phobos reads the mesh of an inertial
    # (a massless link's centre of mass is weighed by volume), so an Empty breaks its export.
    obj = bpy.data.objects.new(f"{link.name}_inertial", _inertial_mesh())
    collection.objects.link(obj)
    obj.parent = parent
    obj.location = centre
    obj.display_type = "WIRE"
    obj.hide_render = True
    obj.phobostype = "inertial"
    obj[keys.MASS] = float(link.mass)
    obj[keys.INERTIA] = inertia


INERTIAL_MESH = "phyrogen_inertial"
INERTIAL_SIZE = 0.03  # the size of Phobos's own inertial boxes


def _inertial_mesh() -> bpy.types.Mesh:
    """The mesh every inertial object shares: a cube of :data:`INERTIAL_SIZE`."""
    mesh = bpy.data.meshes.get(INERTIAL_MESH)
    if mesh is None:
        mesh = bpy.data.meshes.new(INERTIAL_MESH)
        vertices, faces = _box_mesh((INERTIAL_SIZE,) * 3)
        mesh.from_pydata(vertices, [], faces)
        mesh.update()
    return mesh


def _build_geometry(link_name: str, kind: str, index: int, geometry: Geometry, parent: bpy.types.Object,
                    collection: bpy.types.Collection) -> None:
    shape = geometry.shape
    material = _material(geometry.color)
    if isinstance(shape, ConvexPrism):
        parts = [(f"{link_name}_{kind}_{index}_{p}", _prism_mesh(piece, shape.height), "mesh",
                  [float(shape.height)], piece) for p, piece in enumerate(shape.pieces)]
    elif isinstance(shape, Box):
        parts = [(f"{link_name}_{kind}_{index}", _box_mesh(shape.size), "box", list(shape.size), None)]
    elif isinstance(shape, Cylinder):
        parts = [(f"{link_name}_{kind}_{index}", _cylinder_mesh(shape.radius, shape.length), "cylinder",
                  [float(shape.radius), float(shape.length)], None)]
    else:
        raise TypeError(f"link {link_name!r}: unsupported shape {type(shape).__name__}; "
                        "valid: Box, Cylinder, ConvexPrism")
    for piece_index, (name, (vertices, faces), geometry_type, size, piece) in enumerate(parts):
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(vertices, [], faces)
        mesh.update()
        mesh.materials.append(material)
        obj = bpy.data.objects.new(name, mesh)
        collection.objects.link(obj)
        obj.parent = parent
        obj.matrix_basis = _matrix(pose_matrix(geometry.origin))
        obj.phobostype = kind
        obj[keys.GEOMETRY_TYPE] = geometry_type
        obj[keys.GEOMETRY_INDEX] = index
        obj[keys.PIECE_INDEX] = piece_index
        obj[keys.GEOMETRY_NAME] = geometry.name
        obj[keys.ORIGIN] = keys.pose_values(geometry.origin)
        obj[keys.SIZE] = [float(v) for v in size]
        if piece is not None:
            obj[keys.PIECE] = [float(c) for point in piece for c in point]
        if kind == "collision":
            obj.display_type = "WIRE"
            obj.hide_render = True
        elif geometry.color[3] < 1.0:
            obj.show_transparent = True


def _material(rgba: tuple[float, float, float, float]) -> bpy.types.Material:
    """One material per colour, with the colour set both ways (Phobos reads either)."""
    name = "phyrogen_" + color_name(rgba)
    material = bpy.data.materials.get(name)
    if material is not None and tuple(material.get(keys.RGBA, ())) == tuple(rgba):
        return material
    material = bpy.data.materials.new(name)
    material.diffuse_color = rgba
    material[keys.RGBA] = [float(c) for c in rgba]
    material.use_nodes = True
    bsdf = material.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = rgba
        bsdf.inputs["Alpha"].default_value = rgba[3]
    if rgba[3] < 1.0:
        # Blender 4.2+ renamed the transparency switch; keep both spellings working.
        if hasattr(material, "surface_render_method"):
            material.surface_render_method = "BLENDED"
        if hasattr(material, "blend_method"):
            material.blend_method = "BLEND"
    return material


def _box_mesh(size: Sequence[float]) -> tuple[list, list]:
    hx, hy, hz = (s / 2 for s in size)
    vertices = [(x, y, z) for z in (-hz, hz) for x, y in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]
    return vertices, _prism_faces(4)


def _cylinder_mesh(radius: float, length: float) -> tuple[list, list]:
    ring = [(radius * math.cos(2 * math.pi * k / CYLINDER_SEGMENTS),
             radius * math.sin(2 * math.pi * k / CYLINDER_SEGMENTS)) for k in range(CYLINDER_SEGMENTS)]
    return _prism_mesh(ring, length)


def _prism_mesh(ring: Sequence[tuple[float, float]], height: float) -> tuple[list, list]:
    half = height / 2
    vertices = [(x, y, z) for z in (-half, half) for x, y in ring]
    return vertices, _prism_faces(len(ring))


def _prism_faces(n: int) -> list[tuple[int, ...]]:
    bottom = tuple(reversed(range(n)))
    top = tuple(range(n, 2 * n))
    sides = [(i, (i + 1) % n, n + (i + 1) % n, n + i) for i in range(n)]
    return [bottom, top, *sides]


def build_puzzle(puzzle, scene: bpy.types.Scene | None = None) -> PuzzleScene:
    """Build a :class:`~phyrogen_core.puzzle.Puzzle` (goal marker included), keeping its puzzle.json."""
    from phyrogen_core.export import metadata_json

    return build_chain(puzzle.chain, scene, metadata_json(puzzle))


def build_puzzle_folder(folder, scene: bpy.types.Scene | None = None) -> PuzzleScene:
    """Build the puzzle stored in an exported puzzle folder (see ``read_puzzle_dir``)."""
    from pathlib import Path

    from phyrogen_core.export import read_puzzle_dir

    loaded = read_puzzle_dir(folder)
    return build_chain(loaded.chain, scene, (Path(folder) / "puzzle.json").read_text(encoding="utf-8"))


# -- Blender -> chain --------------------------------------------------------
def puzzle_collections(scene: bpy.types.Scene | None = None) -> list[bpy.types.Collection]:
    """The collections in ``scene`` that hold a puzzle, in creation order."""
    scene = scene or bpy.context.scene
    return [c for c in scene.collection.children_recursive if keys.PUZZLE_NAME in c]


def read_chain(collection: bpy.types.Collection) -> KinematicChain:
    """The chain described by the Phobos annotations of the objects in ``collection``.

    Values the scene still agrees with come back exactly; edited transforms,
    sizes and colours are read from the scene. Raises ValueError naming the
    object when the annotations do not describe a chain.
    """
    link_objects = [o for o in collection.all_objects if phobostype(o) == "link"]
    if not link_objects:
        raise ValueError(f"collection {collection.name!r} holds no link objects (phobostype 'link')")
    names = {o: str(o.get(keys.LINK_NAME, o.name)) for o in link_objects}
    roots = [o for o in link_objects if o.parent not in names]
    if len(roots) != 1:
        raise ValueError(f"collection {collection.name!r}: a chain needs exactly one root link (a link whose "
                         f"parent is no link), found {sorted(names[o] for o in roots)}")
    geometries: dict[bpy.types.Object, list[bpy.types.Object]] = {o: [] for o in link_objects}
    inertials: dict[bpy.types.Object, bpy.types.Object] = {}
    for obj in collection.all_objects:
        kind = phobostype(obj)
        if obj.parent in geometries and kind in ("visual", "collision"):
            geometries[obj.parent].append(obj)
        elif obj.parent in geometries and kind == "inertial":
            inertials[obj.parent] = obj

    links: list[tuple[float, Link]] = []
    joints: list[tuple[float, Joint]] = []
    for order, obj in enumerate(sorted(link_objects, key=lambda o: names[o])):
        name = names[obj]
        is_root = obj in roots
        role = Role(obj.get(keys.ROLE, Role.BASE.value if is_root else Role.STATIC.value))
        mass = float(inertials[obj].get(keys.MASS, 1.0)) if obj in inertials else 1.0
        visuals = _read_geometries(obj, [g for g in geometries[obj] if phobostype(g) == "visual"])
        collisions = _read_geometries(obj, [g for g in geometries[obj] if phobostype(g) == "collision"])
        link = Link(name, visuals, collisions, role, str(obj.get(keys.OBJECT, "")), mass)
        links.append((_index(obj, keys.LINK_INDEX, order), link))
        if not is_root:
            origin = keys.snapped_pose(_relative(obj.parent, obj), _list(obj.get(keys.ORIGIN)))
            joint = keys.joint_from_properties(obj, name, names[obj.parent], name, origin)
            joints.append((_index(obj, keys.JOINT_INDEX, order), joint))
    root = roots[0]
    chain_name = str(root.get(keys.MODEL_NAME, collection.get(keys.PUZZLE_NAME, collection.name)))
    return KinematicChain(tuple(link for _, link in sorted(links, key=lambda t: t[0])),
                          tuple(joint for _, joint in sorted(joints, key=lambda t: t[0])),
                          names[root], chain_name)


def _index(obj: bpy.types.Object, key: str, fallback: int) -> float:
    # Objects a user added have no index: they go after the built ones, by name.
    value = obj.get(key)
    return float(value) if value is not None else 1e9 + fallback


def _list(value) -> list[float] | None:
    return None if value is None else [float(v) for v in value]


def _normalized(obj: bpy.types.Object) -> tuple[np.ndarray, np.ndarray]:
    """The world matrix without scale, and the scale."""
    m = _world(obj)
    scale = np.linalg.norm(m[:3, :3], axis=0)
    m[:3, :3] /= scale
    return m, scale


def _world(obj: bpy.types.Object) -> np.ndarray:
    # Computed from the parent chain: objects in hidden collections are not
    # evaluated, so their ``matrix_world`` may be stale.
    local = np.array(obj.matrix_parent_inverse, dtype=float) @ _basis(obj)
    return local if obj.parent is None else _world(obj.parent) @ local


def _basis(obj: bpy.types.Object) -> np.ndarray:
    """The object's own transform; a link's delta transform is left out: it holds the joint's motion
    when a solution is keyframed (:mod:`.animation`), so the puzzle reads the same at every frame."""
    if phobostype(obj) != "link":
        return np.array(obj.matrix_basis, dtype=float)
    if obj.rotation_mode == "QUATERNION":
        rotation = obj.rotation_quaternion.normalized().to_matrix()
    elif obj.rotation_mode == "AXIS_ANGLE":
        angle, *axis = obj.rotation_axis_angle
        rotation = Matrix.Rotation(angle, 3, axis)
    else:
        rotation = obj.rotation_euler.to_matrix()
    return np.array(Matrix.LocRotScale(obj.location, rotation, obj.scale), dtype=float)


def _relative(parent: bpy.types.Object, child: bpy.types.Object) -> np.ndarray:
    return np.linalg.inv(_normalized(parent)[0]) @ _normalized(child)[0]


def _read_geometries(link: bpy.types.Object, objects: Iterable[bpy.types.Object]) -> tuple[Geometry, ...]:
    groups: dict[tuple[float, str], list[bpy.types.Object]] = {}
    for order, obj in enumerate(sorted(objects, key=lambda o: o.name)):
        key = (_index(obj, keys.GEOMETRY_INDEX, order), obj.name if keys.GEOMETRY_INDEX not in obj else "")
        groups.setdefault(key, []).append(obj)
    out = []
    for key in sorted(groups):
        parts = sorted(groups[key], key=lambda o: int(o.get(keys.PIECE_INDEX, 0)))
        first = parts[0]
        origin = keys.snapped_pose(_relative(link, first), _list(first.get(keys.ORIGIN)))
        shapes = [_read_shape(obj) for obj in parts]
        if len(shapes) > 1:
            if not all(isinstance(s, ConvexPrism) for s in shapes):
                raise ValueError(f"objects {[o.name for o in parts]} share geometry index {key[0]:g} "
                                 "but are not all prism pieces (geometry/type mesh)")
            shape = ConvexPrism(tuple(p for s in shapes for p in s.pieces), shapes[0].height)
        else:
            shape = shapes[0]
        out.append(Geometry(shape, origin, _read_color(first), str(first.get(keys.GEOMETRY_NAME, ""))))
    return tuple(out)


def _read_shape(obj: bpy.types.Object) -> Box | Cylinder | ConvexPrism:
    geometry_type = str(obj.get(keys.GEOMETRY_TYPE, "mesh"))
    dimensions = tuple(float(v) for v in obj.dimensions)
    stored = _list(obj.get(keys.SIZE))
    if geometry_type == "box":
        return Box(keys.snapped_values(dimensions, stored))  # type: ignore[arg-type]
    if geometry_type == "cylinder":
        radius, length = keys.snapped_values((dimensions[0] / 2, dimensions[2]), stored)
        return Cylinder(radius, length)
    if geometry_type == "mesh":
        (height,) = keys.snapped_values((dimensions[2],), stored)
        scale = tuple(obj.scale)
        ring = [(v.co.x * scale[0], v.co.y * scale[1]) for v in obj.data.vertices if v.co.z < 0]
        flat = keys.snapped_values([c for p in ring for c in p], _list(obj.get(keys.PIECE)))
        piece = tuple((flat[i], flat[i + 1]) for i in range(0, len(flat), 2))
        return ConvexPrism((piece,), height)
    raise ValueError(f"object {obj.name!r}: geometry/type {geometry_type!r} is not supported; "
                     "valid: box, cylinder, mesh (a convex prism piece)")


def _read_color(obj: bpy.types.Object) -> tuple[float, float, float, float]:
    material = obj.active_material
    if material is None:
        return Geometry.__dataclass_fields__["color"].default
    rgba = keys.snapped_values(tuple(material.diffuse_color), _list(material.get(keys.RGBA)))
    return rgba  # type: ignore[return-value]


def pose_of(obj: bpy.types.Object) -> Pose:
    """The world pose of ``obj`` (scale removed), single precision."""
    return keys.snapped_pose(_normalized(obj)[0], None)
