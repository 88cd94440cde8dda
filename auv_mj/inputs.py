"""Bounded reading of the files and texts users hand to auv-mj: size and nesting checked before parsing.

Every arena or vehicle MJCF, tunnel centreline and JSON option enters through these functions. A file
larger than its limit, XML nested deeper than MAX_XML_DEPTH or with more than MAX_XML_ELEMENTS elements,
and JSON nested deeper than MAX_JSON_DEPTH are refused with a ValueError naming the file, before a
recursive consumer sees them (`json.loads`, `copy.deepcopy` and `ElementTree.tostring` recurse once per
level, MuJoCo's compiler once per body). The checks themselves are scans and cannot recurse.
"""

from __future__ import annotations

import csv
import difflib
import io
import math
import os
import stat
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

MAX_XML_BYTES = 32 * 2**20
"""Largest MJCF file read [bytes]; the shipped tunnel arena is 12 kB."""
MAX_XML_DEPTH = 64
"""Deepest element nesting of an MJCF file; a humanoid's body tree is about 15 deep."""
MAX_XML_ELEMENTS = 100_000
"""Most elements of one MJCF file (geoms, sites, bodies, ...)."""
MAX_TEXT_BYTES = 16 * 2**20
"""Largest text file (CSV or JSON centreline) read [bytes]."""
MAX_JSON_DEPTH = 32
"""Deepest nesting of JSON (objects and arrays); deeper input is refused, not recursed."""

_READ_CHUNK = 1 << 16
CSV_DELIMITERS = {";": "';'", "\t": "tabs", "|": "'|'"}
"""Cell separators other than the comma that spreadsheets write, named as a refusal names them."""


def shown(value: Any, limit: int = 60) -> str:
    """`repr(value)` for a one-line message, cut to about `limit` characters (every layer's errors name the bad
    value this way)."""
    try:
        text = repr(value)
    except Exception:  # a value whose repr fails still gets named by its type
        text = f"<{type(value).__name__}>"
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit] + f"... ({type(value).__name__})"


def did_you_mean(name: Any, valid: Iterable[Any]) -> str:
    """" (did you mean 'x'?)" for the valid name nearest to `name` (difflib's ratio), or "" when none is near: every
    refusal of a name says it, beside the valid set."""
    close = difflib.get_close_matches(str(name), [str(v) for v in valid], n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def unknown_name(what: str, name: Any, valid: Iterable[Any], also: str = "", plural: str | None = None) -> str:
    """The refusal of a name: "unknown policy 'map-replann' (did you mean 'map-replan'?); valid policies: a, b[also]"
    (`plural` where the plural of `what` is not `what` + "s")."""
    valid = [str(v) for v in valid]
    return (f"unknown {what} {shown(name)}{did_you_mean(name, valid)}; valid {plural or what + 's'}: "
            f"{', '.join(valid)}{also}")


def source_name(path: str | Path) -> str:
    """How messages name a file: its path, quoted and escaped if it holds control characters (one line)."""
    text = str(path)
    return text if text.isprintable() else repr(text)


def read_bytes(path: str | Path, what: str, limit: int) -> bytes:
    """The bytes of file `path` (at most `limit`); ValueError naming the file and `what` it should be."""
    name = source_name(path)
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):  # a FIFO or a device could block or never end
            raise ValueError(f"{name}: cannot read {what}: not a regular file")
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    except OSError as e:
        raise ValueError(f"{name}: cannot read {what}: {e.strerror or e}") from None
    except (TypeError, ValueError) as e:  # an embedded NUL, or not a path at all
        if str(e).startswith(name):
            raise
        raise ValueError(f"{name}: cannot read {what}: {e}") from None
    if len(data) > limit:
        raise ValueError(f"{name}: {what} larger than {limit // 2**20} MiB is refused")
    return data


def decode_text(data: bytes, source: str, what: str) -> str:
    """UTF-8 text of `data` without NUL characters; ValueError naming `source` for a binary file."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ValueError(f"{source}: {what} is not UTF-8 text (byte {e.start} is {data[e.start:e.start + 1]!r}; "
                         "a binary file?)") from None
    if "\x00" in text:
        raise ValueError(f"{source}: {what} holds a NUL character at offset {text.index(chr(0))}: a binary file?")
    return text


def read_text(path: str | Path, what: str, limit: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of file `path`, bounded by `limit` bytes; ValueError naming the file."""
    return decode_text(read_bytes(path, what, limit), source_name(path), what)


def json_depth(text: str) -> int:
    """Deepest bracket nesting of JSON text outside strings (a scan, so it cannot recurse)."""
    depth = deepest = 0
    in_string = escaped = False
    for char in text:
        if in_string:
            if escaped:
                escaped = False
            elif char == "\\":
                escaped = True
            elif char == '"':
                in_string = False
            continue
        if char == '"':
            in_string = True
        elif char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth -= 1
    return deepest


def check_json_depth(text: str, source: str, max_depth: int = MAX_JSON_DEPTH) -> None:
    """ValueError naming `source` when `text` nests deeper than `max_depth`."""
    if json_depth(text) > max_depth:
        raise ValueError(f"{source}: JSON nested deeper than {max_depth} levels is refused")


def parse_xml(data: str | bytes, source: str, what: str = "MJCF") -> ET.Element:
    """The root of XML `data`, parsed incrementally so that depth and element count stay bounded.

    ValueError naming `source` for malformed XML, nesting deeper than MAX_XML_DEPTH or more than
    MAX_XML_ELEMENTS elements (expat itself refuses entity expansion bombs).
    """
    if len(data) > MAX_XML_BYTES:
        raise ValueError(f"{source}: {what} larger than {MAX_XML_BYTES // 2**20} MiB is refused")
    parser = ET.XMLPullParser(events=("start", "end"))
    root = None
    depth = count = 0
    view = data if isinstance(data, bytes) else data.encode("utf-8")
    try:
        for offset in range(0, max(len(view), 1), _READ_CHUNK):
            parser.feed(view[offset:offset + _READ_CHUNK])
            for event, element in parser.read_events():
                if event == "end":
                    depth -= 1
                    continue
                depth += 1
                count += 1
                if root is None:
                    root = element
                if depth > MAX_XML_DEPTH:
                    raise ValueError(f"{source}: {what} nested deeper than {MAX_XML_DEPTH} elements "
                                     f"(<{element.tag}> at depth {depth}) is refused")
                if count > MAX_XML_ELEMENTS:
                    raise ValueError(f"{source}: {what} with more than {MAX_XML_ELEMENTS} elements is refused")
        parser.close()
    except ET.ParseError as e:
        raise ValueError(f"{source}: not well-formed XML: {e}") from None
    if root is None:
        raise ValueError(f"{source}: not well-formed XML: no element found")
    return root


def read_xml(path: str | Path, what: str = "MJCF") -> ET.Element:
    """The root element of the XML file `path`, bounded as `parse_xml`; ValueError naming the file."""
    return parse_xml(read_bytes(path, what, MAX_XML_BYTES), source_name(path), what)


def check_element(root: ET.Element, source: str, what: str = "MJCF") -> None:
    """The bounds of `parse_xml` for an element tree built in memory (walked without recursion)."""
    stack: list[tuple[Any, int]] = [(root, 1)]
    count = 0
    while stack:
        element, depth = stack.pop()
        count += 1
        if depth > MAX_XML_DEPTH:
            raise ValueError(f"{source}: {what} nested deeper than {MAX_XML_DEPTH} elements "
                             f"(<{element.tag}> at depth {depth}) is refused")
        if count > MAX_XML_ELEMENTS:
            raise ValueError(f"{source}: {what} with more than {MAX_XML_ELEMENTS} elements is refused")
        stack.extend((child, depth + 1) for child in element)


def _other_delimiter(cell: str) -> str | None:
    """The name of the separator a one-cell CSV row was split with instead of commas, or None."""
    for delimiter, name in CSV_DELIMITERS.items():
        if delimiter in cell:
            return name
    words = cell.split()
    return "spaces" if len(words) > 1 and all(is_number(word) for word in words) else None


def is_number(text: str, finite: bool = False) -> bool:
    """Whether the cell `text` of a user's file reads as a number (`float`), and as a finite one if `finite`."""
    try:
        value = float(text)
    except ValueError:
        return False
    return not finite or math.isfinite(value)


def is_real(value) -> bool:
    """Whether `value` (from a user's JSON or Python) is a finite real number, not a bool."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_)) \
        and math.isfinite(value)


def check_numbers(what: str, checks) -> None:
    """ValueError naming `what` and the field unless each (field, value, low, high) is a finite number in range."""
    for field_name, value, low, high in checks:
        if not (is_real(value) and low <= value <= high):
            raise ValueError(f"{what}: {field_name} = {value!r:.40} must be a finite number in [{low:g}, {high:g}]")


def csv_rows(text: str, source: str, form: str) -> list[list[str]]:
    """The rows of comma-separated `text`; ValueError naming `source` and the row when a row is one cell holding
    another separator (`;`, tabs, `|` or spaces: a spreadsheet's export in another locale), which a comma reader
    would take for one cell. `form` is what a row should look like, e.g. "x,y[,width]". Rows and comments
    (`#` at the start of a row) are checked as they come, so a header separated by semicolons is named too."""
    try:
        table = list(csv.reader(io.StringIO(text)))
    except csv.Error as e:
        raise ValueError(f"{source}: not a CSV file: {e}") from None
    for lineno, cells in enumerate(table, start=1):
        cell = cells[0].split("#", 1)[0].strip() if len(cells) == 1 else ""
        name = _other_delimiter(cell) if cell else None
        if name is not None:
            raise ValueError(f"{source}: row {lineno} {shown(cell, 40)} is one cell separated by {name}: separate "
                             f"the cells with commas ({form})")
    return table
