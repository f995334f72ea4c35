"""Required children and attributes of XML elements, for the project's two URDF readers.

Both readers (``phyrogen_core.export.reader`` for our own folders,
``phyrogen_core.urdf_import`` for URDFs made elsewhere) report a missing
field as one line naming the file and the element; they differ in the error
type, which each gives through its ``error(message)``. Both parse through
:func:`parse_xml`, which refuses a document type declaration.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
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
