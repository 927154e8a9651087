"""The file layer of a Mitsuba XML scene, as Mitsuba 3's parser (src/core/parser.cpp) reads it.

Versions: every file's root names its version; Mitsuba 3 reads files from 0.6 on and upgrades, per
file, those older than 2.0 (`upgrade_from_v1`: camelCase property names to snake_case, a diffuse's
`diffuse_reflectance` to `reflectance`, `uoffset`/`voffset`/`uscale`/`vscale` to a `to_uv`
transform). `<include filename=...>` inserts another file's elements in its place (its root's
children when that root is a <scene>, else the root itself), the name resolved against the including
file's folder first; includes nest, each file at most once on the way down (a cycle is an error,
where Mitsuba stops at a depth limit). `<path value=...>` (a child of the root only) puts a folder,
relative to the file that names it, in front of the folders that later file names (meshes, images)
are looked up in; the scene file's own folder comes last.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

from drtlab.errors import InputError
from drtlab.fields import MAX_NESTING, too_deep

VERSION = re.compile(r"\s*(\d+)(?:\.(\d+))?(?:\.(\d+))?\s*")
OLDEST, NEWEST_MAJOR = (0, 6, 0), 3
UPGRADED_BELOW = (2, 0, 0)
UV_KEYS = {"uoffset": ("translate", "x", 0.0), "voffset": ("translate", "y", 0.0),
           "uscale": ("scale", "x", 1.0), "vscale": ("scale", "y", 1.0)}


def read_root(path: Path) -> ET.Element:
    """The root element of an XML file, or one InputError naming the file."""
    try:
        text = path.read_bytes()
    except OSError as exc:
        raise InputError("scene", f"cannot read {path}: {exc.strerror or exc}") from None
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise InputError("scene", f"malformed XML in {path}: {exc}") from None
    check_depth(root)
    return root


def check_depth(root: ET.Element) -> None:
    """The reader walks elements recursively: a file nested past MAX_NESTING is one line instead
    (5000 levels raised RecursionError)."""
    stack = [(root, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_NESTING:
            raise too_deep("scene")
        stack.extend((child, depth + 1) for child in node)


def parse_version(text: str | None) -> tuple[int, int, int] | None:
    """(major, minor, patch) of a version attribute Mitsuba 3 reads (0.6.0 ... 3.x), else None."""
    m = VERSION.fullmatch(text or "")
    if m is None:
        return None
    version = tuple(int(g or 0) for g in m.groups())
    return version if OLDEST <= version and version[0] <= NEWEST_MAJOR else None


def camel_to_snake(name: str) -> str:
    """Mitsuba's camel_to_underscore_case: an upper-case letter after a lower-case one starts a new
    word, and the upper-case letters right after it join that word (`intIOR` -> `int_ior`)."""
    out, i = [], 0
    while i < len(name):
        c = name[i]
        if i > 0 and name[i - 1].islower() and c.isupper():
            out.append("_" + c.lower())
            while i + 1 < len(name) and name[i + 1].isupper():
                i += 1
                out.append(name[i].lower())
        else:
            out.append(c)
        i += 1
    return "".join(out)


def upgrade_v1(node: ET.Element, property_tags: tuple[str, ...]) -> None:
    """Mitsuba's upgrade_from_v1 on one object element of a file older than 2.0, in place."""
    uv: dict[str, float] = {}
    for child in list(node):
        name = child.get("name")
        if child.tag not in property_tags or not name:
            continue
        name = camel_to_snake(name)
        if node.tag == "bsdf" and node.get("type") == "diffuse" and name == "diffuse_reflectance":
            name = "reflectance"
        child.set("name", name)
        if name in UV_KEYS and child.tag in ("float", "integer"):
            uv[name] = child.get("value", "")
            node.remove(child)
    if uv:
        # to_uv = scale(uscale, vscale) * translate(uoffset, voffset): the translation comes first.
        transform = ET.SubElement(node, "transform", name="to_uv")
        for op in ("translate", "scale"):
            attrs = {axis: uv.get(key, str(default)) for key, (kind, axis, default) in UV_KEYS.items()
                     if kind == op}
            ET.SubElement(transform, op, attrs)
