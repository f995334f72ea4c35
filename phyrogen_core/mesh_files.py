"""Triangle meshes from STL (binary and ASCII) and Wavefront OBJ files, as numpy arrays.

Only what an importer needs: the triangles, as an ``(n, 3, 3)`` float array
(triangle, corner, x/y/z). Normals and colours are ignored. Every problem
(not a mesh, a truncated file, a coordinate that is not a finite number) is
a :class:`MeshFormatError` naming the file.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from .sizes import MESH_TRIANGLES

_BINARY_HEADER = 80
_BINARY_TRIANGLE = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


class MeshFormatError(ValueError):
    """A mesh file that cannot be read as triangles."""


def read_triangles(data: bytes, label: str, suffix: str, limit: float = math.inf) -> np.ndarray:
    """The triangles of a mesh file's bytes; ``suffix`` (``.stl`` or ``.obj``) picks the format.

    Raises :class:`MeshFormatError` ``"<label>: <what is wrong>"`` for an
    unknown format, a malformed or empty file, or a coordinate that is not a
    finite number within +-``limit``.
    """
    suffix = suffix.lower()
    if suffix == ".stl":
        triangles = read_stl(data, label)
    elif suffix == ".obj":
        triangles = read_obj(data, label)
    else:
        raise MeshFormatError(f"{label}: mesh format {suffix or '(none)'!r} is not supported; valid: .stl, .obj")
    too_many = MESH_TRIANGLES.problem(len(triangles))  # before any work that grows with them
    if too_many is not None:
        raise MeshFormatError(f"{label} {too_many}")
    if not np.isfinite(triangles).all() or (limit < math.inf and np.abs(triangles).max() > limit):
        raise MeshFormatError(f"{label}: a vertex coordinate is not a finite number"
                              + (f" within +-{limit:g}" if limit < math.inf else ""))
    return triangles


def read_stl(data: bytes, label: str) -> np.ndarray:
    """The triangles of an STL file, binary or ASCII (``(n, 3, 3)`` float64)."""
    if len(data) >= _BINARY_HEADER + 4:
        count = int.from_bytes(data[_BINARY_HEADER:_BINARY_HEADER + 4], "little")
        if count > 0 and len(data) == _BINARY_HEADER + 4 + count * _BINARY_TRIANGLE.itemsize:
            records = np.frombuffer(data, _BINARY_TRIANGLE, count, _BINARY_HEADER + 4)
            return records["corners"].astype(np.float64)
    if data.lstrip()[:5].lower() == b"solid":
        return _ascii_stl(data, label)
    if len(data) >= _BINARY_HEADER + 4:
        count = int.from_bytes(data[_BINARY_HEADER:_BINARY_HEADER + 4], "little")
        raise MeshFormatError(f"{label}: not an STL file (binary STL of {count} triangles would be "
                              f"{_BINARY_HEADER + 4 + count * _BINARY_TRIANGLE.itemsize} bytes, the file has "
                              f"{len(data)}; an ASCII STL starts with 'solid')")
    raise MeshFormatError(f"{label}: not an STL file ({len(data)} bytes)")


def _text_lines(data: bytes, label: str, encoding: str, what: str) -> Iterator[tuple[int, str, list[str]]]:
    """(number, line, its fields) of each line of a text mesh file that is not blank; MeshFormatError
    when the bytes are not text in ``encoding``."""
    try:
        text = data.decode(encoding)
    except UnicodeDecodeError:
        raise MeshFormatError(f"{label}: {what} must be {encoding.upper()} text") from None
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if fields:
            yield number, line, fields


def _ascii_stl(data: bytes, label: str) -> np.ndarray:
    corners: list[tuple[float, float, float]] = []
    for number, line, fields in _text_lines(data, label, "ascii", "an ASCII STL"):
        if fields[0].lower() != "vertex":
            continue
        try:
            x, y, z = (float(v) for v in fields[1:4])
        except ValueError:
            raise MeshFormatError(f"{label}: line {number}: a vertex needs three numbers, got {line.strip()[:60]!r}") \
                from None
        corners.append((x, y, z))
    if not corners or len(corners) % 3:
        raise MeshFormatError(f"{label}: an ASCII STL needs facets of three vertices each, found {len(corners)} "
                              "vertices")
    return np.array(corners, dtype=np.float64).reshape(-1, 3, 3)


def read_obj(data: bytes, label: str) -> np.ndarray:
    """The triangles of a Wavefront OBJ file: ``v`` lines and ``f`` faces (polygons fanned into triangles)."""
    vertices: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    for number, line, fields in _text_lines(data, label, "utf-8", "an OBJ file"):
        try:
            if fields[0] == "v":
                x, y, z = (float(v) for v in fields[1:4])
                vertices.append((x, y, z))
            elif fields[0] == "f":
                ids = [int(f.split("/")[0]) for f in fields[1:]]
                ids = [i - 1 if i > 0 else len(vertices) + i for i in ids]
                if len(ids) < 3 or not all(0 <= i < len(vertices) for i in ids):
                    raise ValueError
                faces += [(ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1)]
        except ValueError:
            raise MeshFormatError(f"{label}: line {number}: malformed {fields[0]!r} line {line.strip()[:60]!r}") \
                from None
    if not faces:
        raise MeshFormatError(f"{label}: the OBJ file has no faces")
    return np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
