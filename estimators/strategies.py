"""Sampling strategies: how directions and light points are drawn and how the two are combined.

Every strategy is an unbiased estimator of the same image (for a given integrator); they differ only
in variance. Fields are compile-time switches read by the kernel factory.
    direction   "uniform": uniform hemisphere (sphere for transmissive lobes); "lobe": cosine for
                diffuse, the Phong lobe for glossy reflection/transmission, Fresnel for the lobe choice
    light       "area": uniform area on the chosen light; "solid_angle": uniform in the cone a sphere
                light subtends (rectangles stay area-sampled); None: no light sampling
    light_pick  "uniform" over lights or "power" (proportional to emitted power)
    combine     "nee": emitters count only through light samples after a non-delta bounce;
                "bsdf": only through scattered rays; "mis": both, power heuristic (Veach 1995)
"""
from dataclasses import dataclass


@dataclass(frozen=True)
class Strategy:
    name: str
    description: str
    direction: str
    light: str | None
    light_pick: str
    combine: str


STRATEGIES = {s.name: s for s in (
    Strategy("uniform", "uniform directions and uniform light area, next-event estimation",
             "uniform", "area", "uniform", "nee"),
    Strategy("importance", "BSDF-lobe and solid-angle light sampling combined by MIS (power heuristic)",
             "lobe", "solid_angle", "power", "mis"),
    Strategy("light", "light sampling only (solid angle), BSDF-lobe continuation",
             "lobe", "solid_angle", "power", "nee"),
    Strategy("bsdf", "BSDF-lobe sampling only, emitters found by scattered rays",
             "lobe", None, "power", "bsdf"),
)}
