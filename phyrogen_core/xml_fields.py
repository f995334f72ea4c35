"""Required children and attributes of XML elements, for the project's two URDF readers.

Both readers (``phyrogen_core.export.reader`` for our own folders,
``phyrogen_core.urdf_import`` for URDFs made elsewhere) report a missing
field as one line naming the file and the element; they differ in the error
type, which each gives through its ``error(message)``. Both parse through
:func:`parse_xml`, which refuses a document type declaration.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable
from xml.parsers import expat

DTD_REFUSED = ("holds a document type declaration (<!DOCTYPE ...>); a URDF needs none, and its entities "
               "could expand the file far past its stated size")


class DoctypeError(ValueError):
    """An XML document with a DTD: :data:`DTD_REFUSED`."""


class _PrologEndedError(Exception):
    """The root element began: no DTD can follow."""


def _refuse(*_: object) -> None:
    raise DoctypeError(DTD_REFUSED)


def _stop(*_: object) -> None:
    raise _PrologEndedError


def parse_xml(data: bytes | str) -> ET.Element:
    """``ET.fromstring(data)``, but a document with a DTD raises :class:`DoctypeError`.

    A DTD is where entities are declared (parameter entities included), and
    ElementTree expands internal ones: refusing every DTD refuses them all,
    whatever they hold. A DTD can only come before the root element, so the
    scan stops there; malformed XML is left for ElementTree to report.
    """
    scanner = expat.ParserCreate()
    scanner.StartDoctypeDeclHandler = _refuse
    scanner.StartElementHandler = _stop
    try:
        scanner.Parse(data, True)
    except (_PrologEndedError, expat.ExpatError):
        pass
    return ET.fromstring(data)


def parse_urdf(data: bytes | str, where: str, error: Callable[[str], Exception]) -> ET.Element:
    """The ``<robot>`` element of a URDF document (:func:`parse_xml`), its size within the bounds
    (:func:`~phyrogen_core.sizes.urdf_size_problem`: checked before any mesh is read); a DTD, malformed
    XML, another root element or a size beyond them raises ``error(message)``, the message naming ``where``."""
    from .sizes import urdf_size_problem

    try:
        robot = parse_xml(data)
    except DoctypeError as exc:
        raise error(f"{where}: the URDF {exc}") from None
    except ET.ParseError as exc:
        raise error(f"{where}: not a URDF file: malformed XML: {exc}") from None
    if robot.tag != "robot":
        raise error(f"{where}: not a URDF file: the root element is <{robot.tag}>, not <robot>")
    too_large = urdf_size_problem(robot)
    if too_large is not None:
        raise error(f"{where}: the URDF {too_large}")
    return robot


class XmlFields:
    """Mix-in: ``child`` and ``attribute`` raise ``self.error(...)`` when the field is missing."""

    def error(self, message: str) -> Exception:
        raise NotImplementedError

    def child(self, element: ET.Element, tag: str, where: str) -> ET.Element:
        found = element.find(tag)
        if found is None:
            raise self.error(f"{where}: missing <{tag}>")
        return found

    def attribute(self, element: ET.Element, name: str, where: str) -> str:
        value = element.get(name)
        if value is None:
            raise self.error(f"{where}: missing attribute {name!r}")
        return value
