"""Mitsuba 3's named conductors (`material="Cu"`, ...) as the RGB complex indices of refraction its
RGB variants render: writes kernels/scene_model/mitsuba_conductor_ior.py.

Mitsuba reads each material's measured spectra (data/ior/NAME.eta.spd, .k.spd) and, in an RGB
variant, turns each into one sRGB colour (ior.h, ior_from_file: spectrum_list_to_srgb, unbounded).
This asks Mitsuba itself for those colours, through the `eta` and `k` of a loaded conductor, so the
table is Mitsuba's numbers, not a re-derivation:
    python -m drtlab.experiments.bench.mitsuba.conductor_ior
"""
from __future__ import annotations

from pathlib import Path

OUT = Path(__file__).resolve().parents[3] / "kernels" / "scene_model" / "mitsuba_conductor_ior.py"
COMMAND = "python -m drtlab.experiments.bench.mitsuba.conductor_ior"


def table() -> dict[str, tuple[tuple[float, ...], tuple[float, ...]]]:
    """Material name -> ((eta r, g, b), (k r, g, b)), every material Mitsuba's data holds."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    folder = Path(mi.__file__).parent / "data" / "ior"
    names = sorted(p.name[:-len(".eta.spd")] for p in folder.glob("*.eta.spd")
                   if (folder / p.name.replace(".eta.", ".k.")).exists())
    out = {}
    for name in names:
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        out[name] = tuple(tuple(float(x) for x in params[f"{key}.value"]) for key in ("eta", "k"))
    return out


def main() -> None:
    rows = "\n".join(f"    {name!r}: ({eta!r}, {k!r})," for name, (eta, k) in table().items())
    OUT.write_text(f'''"""Mitsuba 3's named conductors as its RGB variants render them: material name -> ((eta r, g, b),
(k r, g, b)), complex index n = eta + i k of the metal (Mitsuba's conductors have no exterior index).
Generated from Mitsuba itself, do not edit: {COMMAND}
"""
CONDUCTOR_IOR = {{
{rows}
}}
''')
    print(f"wrote {OUT} ({len(rows.splitlines())} materials)")


if __name__ == "__main__":
    main()
