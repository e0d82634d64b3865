"""XML parsing for calibration files without DTDs, entities or external references.

A calibration file never needs a DOCTYPE; one that declares it (the shape of a billion-laughs or
an external-entity file) is refused before any parsing, in time and memory bounded by the file's
size, and so is a file larger than MAX_XML_BYTES.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

from ...errors import InputError

MAX_XML_BYTES = 64 * 1024 * 1024  # a rig's calibration is kilobytes; refuse anything this large
_DECLARATIONS = re.compile(rb"<!\s*(DOCTYPE|ENTITY|ELEMENT|ATTLIST|NOTATION)", re.IGNORECASE)


def parse_xml(path: Path, what: str) -> ET.Element:
    """The root element of an XML calibration file; InputError for DTDs, entities, bad XML."""
    size = path.stat().st_size
    if size > MAX_XML_BYTES:
        raise InputError(f"{path}: {size} bytes is too large for a {what} calibration file")
    data = path.read_bytes()
    m = _DECLARATIONS.search(data)
    if m:
        raise InputError(f"{path}: the {what} file declares <!{m.group(1).decode()}>; calibration "
                         f"files never need DTDs or entities, so it is refused unread")
    try:
        parser = ET.XMLParser()
        parser.feed(data)
        return parser.close()
    except ET.ParseError as exc:
        raise InputError(f"{path}: not valid XML for a {what} file ({exc})") from None
