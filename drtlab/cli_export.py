"""`drtlab export SCENE --format mitsuba OUT.xml`: a scene as a Mitsuba 3 XML file
(kernels/scene_model/mitsuba_export.py). Bad input, and a scene with something Mitsuba 3 has no counterpart for,
is one line naming the field and exit 2, before anything is written."""
from __future__ import annotations

from pathlib import Path

from drtlab import fields
from drtlab.cli_args import Help, parse_overrides
from drtlab.errors import InputError

FORMATS = ("mitsuba",)


def cmd_export(args) -> int:
    from drtlab.kernels.scene_model.mitsuba_export import check_exportable, export_mitsuba
    from drtlab.kernels.scene_model.scene_file import load_scene, scene_data
    out = Path(args.out).expanduser()
    if out.suffix.lower() != ".xml":
        raise InputError("OUT", f"must be a path ending in .xml, got {str(out)!r}")
    fields.writable_location(out, "OUT")
    overrides = parse_overrides(args.set)
    scene = load_scene(args.scene, overrides)
    check_exportable(scene)
    out.parent.mkdir(parents=True, exist_ok=True)
    written = export_mitsuba(scene, out, scene_data(args.scene, overrides), field="OUT")
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0


def add_export_command(sub) -> None:
    """The `export` subcommand on the parser's subparsers `sub`."""
    p = sub.add_parser(
        "export", help="write a scene as a Mitsuba 3 XML file", formatter_class=Help,
        description="Write SCENE (a built-in name, a .toml or a Mitsuba .xml path) as a Mitsuba 3 "
                    "XML file whose import renders bit-identically in drtlab: the path integrator; "
                    "diffuse, mirror, beckmann, dielectric and emitter materials; quads, boxes (as six "
                    "rectangles), spheres, meshes (PLY files beside OUT); point, spot and directional "
                    "lights; a constant environment; pinhole or thin-lens camera; box or mitchell filter. "
                    "Anything else (drt, whitted, Phong lobes, GGX, checkers, motion) is refused "
                    "in one line, exit 2.")
    p.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a .toml or .xml scene")
    p.add_argument("out", metavar="OUT", help="the .xml file to write")
    p.add_argument("--format", choices=FORMATS, default="mitsuba", help="output format")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", default=None,
                   help="override a scene value first, e.g. --set scene.spp=64 (repeatable; TOML values)")
    p.set_defaults(func=cmd_export)
