"""Reading a Mitsuba 3 XML file: elements, typed properties, `<default>`/`$name`, ids and transforms.

This is the XML layer of the importer (`mitsuba_import.py` maps what it reads onto a drtlab scene).
Every element gets a path as the user would point at it (`scene/shape[3](rectangle)/bsdf(diffuse)/
float[@name=alpha]`), and every problem is one `InputError` whose field is "FILE: PATH". Values are
parsed as Mitsuba 3's parser does (src/core/parser.cpp): numbers with separators ", ", `<rgb>` of one
or three values, `<spectrum>` of one constant value, transforms whose later operations left-multiply
the earlier ones. Non-finite numbers are refused (drtlab's scene numbers are finite).
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import MAX_NESTING, too_deep

OBJECT_TAGS = ("scene", "shape", "bsdf", "emitter", "sensor", "film", "rfilter", "sampler",
               "integrator", "texture", "medium", "phase", "volume")
PROPERTY_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector",
                 "transform", "ref")
_SEPARATORS = re.compile(r"[,\s]+")
_PARAM = re.compile(r"(?<!\\)\$([A-Za-z0-9_]+)")


class XmlError(InputError):
    """One problem at one element of the file."""


@dataclass
class Prop:
    tag: str            # float, rgb, transform, ref, or an object tag for a nested object
    value: object       # the parsed value; a nested object's Obj; a ref's id
    path: str


@dataclass
class Ref:
    id: str
    path: str


@dataclass
class Obj:
    """One object element (<shape type="sphere">): its properties by name, nested objects in order."""
    tag: str
    type: str
    path: str
    id: str | None
    props: dict[str, Prop] = field(default_factory=dict)
    children: list[Obj | Ref] = field(default_factory=list)     # nested objects and refs, in order
    used: set[str] = field(default_factory=set)


def _check_depth(root: ET.Element) -> None:
    """The reader walks elements recursively: a file nested past MAX_NESTING is one line instead
    (5000 levels raised RecursionError)."""
    stack = [(root, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_NESTING:
            raise too_deep("scene")
        stack.extend((child, depth + 1) for child in node)


class Reader:
    """The parsed file: `root` (the <scene>), objects by id, and the file name for messages."""

    def __init__(self, path: Path):
        self.file = path.name
        self.folder = path.parent
        try:
            text = path.read_bytes()
        except OSError as exc:
            raise InputError("scene", f"cannot read {path}: {exc.strerror or exc}") from None
        try:
            root = ET.fromstring(text)
        except ET.ParseError as exc:
            raise InputError("scene", f"malformed XML in {path}: {exc}") from None
        _check_depth(root)
        self.params: dict[str, str] = {}
        self.ids: dict[str, Obj] = {}
        if root.tag != "scene":
            self.fail(root.tag, f"the root element must be <scene version=\"3.x\">, got <{root.tag}>")
        self._substitute(root, "scene")
        version = root.get("version")
        if version is None or not re.fullmatch(r"3(\.\d+){0,2}", version.strip()):
            self.fail("scene", f"version must be 3.x (Mitsuba 3), got {version!r}")
        self.root = self._object(root, "scene")

    def fail(self, path: str, message: str):
        raise XmlError(f"{self.file}: {path}", message)

    # ---- <default> and $name, in document order as Mitsuba substitutes them ----------------------
    def _substitute(self, node: ET.Element, path: str) -> None:
        for key, value in node.attrib.items():
            def sub(match):
                if match.group(1) not in self.params:
                    self.fail(path, f"undefined parameter ${match.group(1)} in {key}={value!r} "
                                    "(define it with <default name=... value=...>)")
                return self.params[match.group(1)]
            node.set(key, _PARAM.sub(sub, value).replace("\\$", "$"))
        if node.tag == "default":
            name, value = node.get("name"), node.get("value")
            if not name or value is None:
                self.fail(path, "<default> needs a non-empty name and a value")
            self.params.setdefault(name, value)
        for child, child_path in self._children(node, path):
            self._substitute(child, child_path)

    @staticmethod
    def _children(node: ET.Element, path: str):
        counts: dict[str, int] = {}
        for child in node:
            counts[child.tag] = counts.get(child.tag, 0) + 1
        seen: dict[str, int] = {}
        for child in node:
            seen[child.tag] = seen.get(child.tag, 0) + 1
            name = child.tag + (f"[{seen[child.tag]}]" if counts[child.tag] > 1 else "")
            if child.tag in PROPERTY_TAGS and child.tag != "ref" and child.get("name"):
                name = f"{child.tag}[@name={child.get('name')}]"
            elif child.get("type"):
                name += f"({child.get('type')})"
            yield child, f"{path}/{name}"

    # ---- objects and properties --------------------------------------------------------------------
    def _object(self, node: ET.Element, path: str) -> Obj:
        allowed = {"version", "type", "id", "name"} if node.tag == "scene" else {"type", "id", "name"}
        self._attributes(node, path, allowed)
        if node.tag != "scene" and not node.get("type"):
            self.fail(path, f"<{node.tag}> needs a type attribute")
        obj = Obj(node.tag, node.get("type", "scene"), path, node.get("id"))
        if obj.id is not None:
            if obj.id in self.ids:
                self.fail(path, f"duplicate id '{obj.id}'")
            self.ids[obj.id] = obj
        for child, child_path in self._children(node, path):
            if child.tag == "default":
                continue
            if child.tag in OBJECT_TAGS:
                nested = self._object(child, child_path)
                name = child.get("name")
                if name:
                    self._set(obj, name, Prop(child.tag, nested, child_path), child_path)
                obj.children.append(nested)
            elif child.tag == "ref":
                self._attributes(child, child_path, {"id", "name"})
                if not child.get("id"):
                    self.fail(child_path, "<ref> needs an id")
                if child.get("name"):
                    self._set(obj, child.get("name"), Prop("ref", child.get("id"), child_path), child_path)
                obj.children.append(Ref(child.get("id"), child_path))
            elif child.tag in PROPERTY_TAGS:
                name = child.get("name")
                if not name:
                    self.fail(child_path, f"<{child.tag}> needs a name attribute")
                self._set(obj, name, Prop(child.tag, self._value(child, child_path), child_path),
                          child_path)
            else:
                self.fail(child_path, f"<{child.tag}> is not supported (supported elements: "
                                      f"{', '.join(OBJECT_TAGS[:9] + PROPERTY_TAGS)}, default)")
        return obj

    def _set(self, obj: Obj, name: str, prop: Prop, path: str) -> None:
        if name in obj.props:
            self.fail(path, f"property '{name}' is given twice")
        obj.props[name] = prop

    def _attributes(self, node: ET.Element, path: str, allowed: set[str]) -> None:
        extra = sorted(set(node.attrib) - allowed)
        if extra:
            self.fail(path, f"unexpected attribute '{extra[0]}' (allowed: {', '.join(sorted(allowed))})")

    def _value(self, node: ET.Element, path: str):
        tag = node.tag
        if tag == "transform":
            self._attributes(node, path, {"name"})
            return [self._operation(c, p) for c, p in self._children(node, path)]
        if tag in ("point", "vector"):
            self._attributes(node, path, {"name", "value", "x", "y", "z"})
            return self._xyz(node, path, 0.0)
        self._attributes(node, path, {"name", "value"})
        text = node.get("value")
        if text is None:
            self.fail(path, f"<{tag}> needs a value")
        if tag == "float":
            return self.number(text, path)
        if tag == "integer":
            if not re.fullmatch(r"\s*[-+]?\d+\s*", text):
                self.fail(path, f"could not parse integer value {text!r}")
            return int(text)
        if tag == "boolean":
            if text.strip().lower() not in ("true", "false"):
                self.fail(path, f"could not parse boolean value {text!r} (true or false)")
            return text.strip().lower() == "true"
        if tag == "string":
            return text
        values = [self.number(t, path) for t in _SEPARATORS.split(text.strip()) if t]
        if tag == "spectrum" and len(values) != 1:
            self.fail(path, "only a constant <spectrum> (one value) is supported: drtlab renders RGB")
        if len(values) not in (1, 3):
            self.fail(path, f"<rgb> takes one or three values, got {len(values)}")
        return values * 3 if len(values) == 1 else values

    def number(self, text: str, path: str) -> float:
        try:
            value = float(text)
        except ValueError:
            self.fail(path, f"could not parse a number from {text!r}")
        if not math.isfinite(value):
            self.fail(path, f"must be a finite number, got {text!r}")
        return value

    def _xyz(self, node: ET.Element, path: str, default: float) -> list[float]:
        if node.get("value") is not None:
            if any(node.get(k) is not None for k in "xyz"):
                self.fail(path, "give either value or x, y, z, not both")
            values = [self.number(t, path) for t in _SEPARATORS.split(node.get("value").strip()) if t]
            if len(values) not in (1, 3):
                self.fail(path, f"value takes one or three numbers, got {len(values)}")
            return values * 3 if len(values) == 1 else values
        return [self.number(node.get(k), path) if node.get(k) is not None else default for k in "xyz"]

    def _operation(self, node: ET.Element, path: str):
        """One operation of a <transform>, as (kind, 4x4 matrix, parameters)."""
        from drtlab.kernels.scene_model.transforms import rotation, scaling, translation
        if node.tag == "translate":
            self._attributes(node, path, {"value", "x", "y", "z"})
            v = self._xyz(node, path, 0.0)
            return ("translate", translation(v), v)
        if node.tag == "scale":
            self._attributes(node, path, {"value", "x", "y", "z"})
            v = self._xyz(node, path, 1.0)
            if 0.0 in v:
                self.fail(path, f"a scale factor of 0 makes the transform singular, got {v}")
            return ("scale", scaling(v), v)
        if node.tag == "rotate":
            self._attributes(node, path, {"value", "x", "y", "z", "angle"})
            axis = self._xyz(node, path, 0.0)
            if node.get("angle") is None:
                self.fail(path, "<rotate> needs an angle (degrees)")
            if not any(axis):
                self.fail(path, "the rotation axis cannot be zero")
            angle = self.number(node.get("angle"), path)
            return ("rotate", rotation(axis, angle), (axis, angle))
        if node.tag == "matrix":
            self._attributes(node, path, {"value"})
            values = [self.number(t, path) for t in _SEPARATORS.split((node.get("value") or "").strip()) if t]
            if len(values) not in (9, 16):
                self.fail(path, f"a matrix has 9 or 16 values, got {len(values)}")
            m = np.eye(4)
            n = 4 if len(values) == 16 else 3
            m[:n, :n] = np.array(values).reshape(n, n)
            if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
                self.fail(path, f"the last row must be 0 0 0 1 (an affine transform), got {m[3].tolist()}")
            return ("matrix", m, m)
        if node.tag == "lookat":
            self._attributes(node, path, {"origin", "target", "up"})
            origin, target = (self._vector(node, k, path) for k in ("origin", "target"))
            up = self._vector(node, "up", path) if node.get("up") else [0.0, 0.0, 0.0]
            direction = np.subtract(target, origin)
            if not np.any(direction):
                self.fail(path, "origin and target must differ")
            if not any(up):
                up = coordinate_up(direction / np.linalg.norm(direction))
            m = look_at(origin, target, up)
            if not np.all(np.isfinite(m)):
                self.fail(path, "invalid lookat (up parallel to the view direction)")
            return ("lookat", m, (origin, target, up))
        self.fail(path, f"<{node.tag}> is not a transform operation (translate, scale, rotate, "
                        "matrix, lookat)")

    def _vector(self, node: ET.Element, key: str, path: str) -> list[float]:
        text = node.get(key)
        if text is None:
            self.fail(path, f"<lookat> needs {key}")
        values = [self.number(t, path) for t in _SEPARATORS.split(text.strip()) if t]
        if len(values) != 3:
            self.fail(path, f"{key} takes three numbers, got {len(values)}")
        return values


def look_at(origin, target, up) -> np.ndarray:
    """Mitsuba's Transform4f::look_at: columns (left, up', dir, origin), left = up x dir."""
    d = np.subtract(target, origin, dtype=np.float64)
    d = d / np.linalg.norm(d)
    with np.errstate(invalid="ignore", divide="ignore"):
        left = np.cross(np.asarray(up, dtype=np.float64), d)
        left = left / np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, origin
    return m


def coordinate_up(n: np.ndarray) -> list[float]:
    """The first vector of Mitsuba's coordinate_system(n) (Duff et al. 2017): lookat's up when none
    is given."""
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    # Dr.Jit's mulsign(x, y): x with its sign flipped where y is negative (not copysign).
    return [sign * (n[0] * n[0] * a) + 1.0, sign * (n[0] * n[1] * a), -sign * n[0]]


# ---------------------------------------------------------------------------------------------------
# Transform chains: a list of (kind, matrix, parameters), applied first to last
# ---------------------------------------------------------------------------------------------------

def chain_matrix(chain) -> np.ndarray:
    m = np.eye(4)
    for _, op, _ in chain:
        m = op @ m
    return m


def chain_point(chain, p) -> np.ndarray:
    """p through each operation in turn (not through the composed matrix: an exporter's chain that
    maps a corner exactly stays exact)."""
    p = np.asarray(p, dtype=np.float64)
    for _, op, _ in chain:
        p = op[:3, :3] @ p + op[:3, 3]
    return p


def chain_vector(chain, v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    for _, op, _ in chain:
        v = op[:3, :3] @ v
    return v


def drtlab_transform(chain) -> dict | None:
    """A shape's chain as drtlab's `transform` table: scale, rotations, translate when it has that
    order (Mitsuba's usual `translate @ rotate @ scale`, kept exactly as written), else its matrix."""
    if not chain:
        return None
    kinds = [k for k, _, _ in chain]
    ordered = (kinds.count("scale") <= 1 and kinds.count("translate") <= 1
               and set(kinds) <= {"scale", "rotate", "translate"}
               and kinds == sorted(kinds, key=("scale", "rotate", "translate").index))
    if not ordered:
        return {"matrix": chain_matrix(chain).tolist()}
    table: dict = {}
    for kind, _, params in chain:
        if kind == "scale":
            table["scale"] = list(params)
        elif kind == "translate":
            table["translate"] = list(params)
        else:
            table.setdefault("rotate", []).append({"axis": list(params[0]), "degrees": params[1]})
    return table


# Mitsuba's named indices of refraction (include/mitsuba/render/ior.h).
IOR_PRESETS = {"vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
               "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
               "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501,
               "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
               "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046,
               "sodium chloride": 1.544, "amber": 1.55, "pet": 1.5750, "diamond": 2.419}
