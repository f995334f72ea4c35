"""Required children and attributes of XML elements, for the project's two URDF readers.

Both readers (``phyrogen_core.export.reader`` for our own folders,
``phyrogen_core.urdf_import`` for URDFs made elsewhere) report a missing
field as one line naming the file and the element; they differ in the error
type, which each gives through its ``error(message)``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET


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
