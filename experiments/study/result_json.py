"""Typed results to and from JSON (summary.json): `to_json` turns a result into plain Python
values, `from_json` rebuilds a result class from them, nested results from the field types. Generic
over dataclasses: a class whose `to_json` leaves non-finite floats out as None sets
`NULLS_ARE_NAN = True`, and its nulls come back as NaN."""
from __future__ import annotations

import types
import typing
from dataclasses import MISSING, fields, is_dataclass

NAN = float("nan")


def to_json(o):
    """A result (dataclass, dict, list, tuple or plain value) as plain JSON-ready Python values."""
    if hasattr(o, "to_json"):
        return o.to_json()
    if is_dataclass(o):
        return {f.name: to_json(getattr(o, f.name)) for f in fields(o)}
    if isinstance(o, dict):
        return {k: to_json(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [to_json(v) for v in o]
    return o


def from_json(cls, data, where: str = "summary"):
    """The inverse of `to_json`: a result class from its JSON (as summary.json holds it), nested
    results rebuilt from the field types. Keys the class does not name are derived values (a cell's
    `study_error`) and are skipped; a missing required one raises ValueError naming where."""
    if not isinstance(data, dict):
        raise ValueError(f"{where}: expected an object, got {type(data).__name__}")
    hints, kw = typing.get_type_hints(cls), {}
    for f in fields(cls):
        key = cls.json_key(f.name) if hasattr(cls, "json_key") else f.name
        if key not in data:
            if f.default is MISSING and f.default_factory is MISSING:
                raise ValueError(f"{where}: no '{key}'")
        elif data[key] is None and getattr(cls, "NULLS_ARE_NAN", False):
            kw[f.name] = NAN        # their to_json leaves None out: a null was a non-finite float
        else:
            kw[f.name] = decode(hints[f.name], data[key], f"{where}.{key}")
    return cls(**kw)


def decode(tp, v, where: str):
    if v is None:
        return NAN if tp is float else None         # the JSON writer turned NaN and inf into null
    origin, args = typing.get_origin(tp), [a for a in typing.get_args(tp) if a is not type(None)]
    if origin in (typing.Union, types.UnionType):
        return decode(args[0], v, where)
    if origin is list:
        return [decode(args[0], x, f"{where}[{i}]") for i, x in enumerate(v)]
    if origin is dict:
        return {k: decode(args[1], x, f"{where}.{k}") for k, x in v.items()}
    return from_json(tp, v, where) if is_dataclass(tp) else v


def fields_json(o, skip_none: bool = False, **special) -> dict:
    """A dataclass's fields in order; `special[name](value)` where given, else `to_json(value)`."""
    out = {}
    for f in fields(o):
        v = getattr(o, f.name)
        if not (skip_none and v is None):
            out[f.name] = special[f.name](v) if f.name in special else to_json(v)
    return out
