"""A Mitsuba 3 XML scene -> a drtlab scene dict (SCENE_FORMAT.md, "Mitsuba 3 XML").

Only what drtlab renders exactly as Mitsuba 3 (an RGB variant) would is accepted: every element,
plugin and property outside that subset is refused, before any rendering, with one line naming its
path in the file. Properties that cannot change the image (clip planes, the film's file formats, a
pinhole's focus distance, the sampler's seed) are accepted and dropped. The dict then goes through
drtlab's own loader (scene_tables.build_scene) like a TOML file's.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from drtlab.kernels.scene_model.light_projection import FOV_AXES, focal_length_fov, fov_x, resolved_axis
from drtlab.kernels.scene_model.mitsuba_materials import MaterialMapping
from drtlab.kernels.scene_model.mitsuba_shapes import ShapeMapping
from drtlab.kernels.filters import MITSUBA_GAUSSIAN, MITSUBA_STDDEV, STDDEV_MAX, STDDEV_MIN
from drtlab.kernels.scene_model.mitsuba_spectrum import spectrum_to_rgb
from drtlab.kernels.scene_model.mitsuba_textures import TEXTURES
from drtlab.kernels.scene_model.mitsuba_xml import Obj, Prop, Reader, Ref, Spectrum, chain_matrix

# `moment` wraps the integrator whose image it renders (its second moments are extra channels);
# `ptracer` traces from the lights, an image equal in expectation to `path`'s, which renders it.
INTEGRATORS, WRAPPERS = ("path", "direct", "ptracer"), ("moment",)
SENSORS = ("perspective", "thinlens", "orthographic")
NEAR_CLIP = 0.01            # Mitsuba's ProjectiveCamera default
SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")


def scene_dict(path: Path) -> tuple[dict, str]:
    """(drtlab scene dict, the XML text) of a Mitsuba 3 XML file; one InputError on anything else."""
    r = Reader(path)
    return _Importer(r).convert(), path.read_text(encoding="utf-8", errors="replace")


class _Importer(ShapeMapping, MaterialMapping):
    def __init__(self, r: Reader):
        self.r = r
        self.materials: dict[str, dict] = {}
        self.material_of: dict[tuple, str] = {}
        self.data: dict = {"materials": self.materials, "shapes": []}
        self.integrated = False
        self.instances = 0
        self.notes: list[str] = []      # what the scene's description says drtlab did differently

    # ---- property access: each read marks the property used; `done` refuses the rest -------------
    def get(self, o: Obj, name: str, tags: tuple[str, ...], default=None):
        p = o.props.get(name)
        if p is None:
            return default
        o.used.add(name)
        if p.tag == "texture" and "texture" not in tags:
            self.r.fail(p.path, f"<texture type='{p.value.type}'> is not supported here (drtlab reads "
                                f"{' or '.join('<' + t + '>' for t in tags)})")
        if p.tag not in tags:
            self.r.fail(p.path, f"must be {' or '.join('<' + t + '>' for t in tags)}, got <{p.tag}>")
        return p.value

    def number(self, o: Obj, name: str, default, rule=None, text=""):
        v = self.get(o, name, ("float", "integer"), default)
        if rule is not None and v is not None and not rule(v):
            self.r.fail(o.props[name].path, f"must be {text}, got {v!r}")
        return v

    def colour(self, o: Obj, name: str, default, emitter: bool = False, unbounded: bool = False):
        """An RGB property as Mitsuba's RGB variants read it: <rgb>, <float>, <spectrum> (as
        mitsuba_spectrum.py), or a constant texture (`srgb` with a `color`, `uniform` with a
        `value`) where a plain value is meant; `emitter` for an emitter's radiance, irradiance or
        intensity."""
        p = o.props.get(name)
        if p is not None and p.tag == "ref":
            p = Prop("texture", self.deref(Ref(p.value, p.path)), p.path)
        if p is not None and p.tag == "texture":
            o.used.add(name)
            return self.constant_texture(p.value, emitter, unbounded)
        v = self.get(o, name, ("rgb", "spectrum", "float"), default)
        if isinstance(v, Spectrum):
            return spectrum_to_rgb(v.wavelengths, v.values, emitter, unbounded)
        return [float(v)] * 3 if isinstance(v, (int, float)) else list(v)

    def constant_texture(self, t: Obj, emitter: bool, unbounded: bool) -> list[float]:
        if t.tag != "texture" or t.type not in ("srgb", "uniform"):
            self.r.fail(t.path, f"<{t.tag} type='{t.type}'> is not supported here (drtlab reads "
                                "constant values: <rgb>, <spectrum>, <float>, srgb or uniform "
                                "textures)")
        key = "color" if t.type == "srgb" else "value"
        if key not in t.props:
            self.r.fail(t.path, f"a {t.type} texture needs {key}")
        rgb = self.colour(t, key, None, emitter, unbounded)
        self.done(t)
        return rgb

    def string(self, o: Obj, name: str, default, choices=None):
        v = self.get(o, name, ("string",), default)
        if choices is not None and v not in choices:
            self.r.fail(o.props[name].path, f"{v!r} is not supported (supported: {', '.join(choices)})")
        return v

    def ignore(self, o: Obj, *names: str) -> None:
        o.used.update(n for n in names if n in o.props)

    def done(self, o: Obj) -> None:
        for name, p in o.props.items():
            if name not in o.used:
                self.r.fail(p.path, f"property '{name}' of {o.tag} '{o.type}' is not supported")

    def kind(self, o: Obj, supported: tuple[str, ...]) -> str:
        if o.type not in supported:
            self.r.fail(o.path, f"{o.tag} type '{o.type}' is not supported (supported: {', '.join(supported)})")
        return o.type

    def nested(self, o: Obj) -> list[Obj]:
        """o's nested objects and references, in order (a `name` on one is only its label)."""
        o.used.update(n for n, p in o.props.items() if p.tag == "ref" or isinstance(p.value, Obj))
        return [self.deref(c) for c in o.children]

    def deref(self, child: Obj | Ref) -> Obj:
        if isinstance(child, Ref):
            if child.id not in self.r.ids:
                self.r.fail(child.path, f"id '{child.id}' names no object")
            return self.r.ids[child.id]
        return child

    # ---- the scene ---------------------------------------------------------------------------------
    def convert(self) -> dict:
        root = self.r.root
        # A `name` on an object in <scene> (Mitsuba's writer gives every one) is only its label.
        root.used.update(n for n, p in root.props.items() if p.tag == "ref" or isinstance(p.value, Obj))
        self.done(root)
        sensors = []
        for child in root.children:
            if isinstance(child, Ref):
                self.r.fail(child.path, "a <ref> directly in <scene> is not supported")
            if child.tag == "sensor":
                sensors.append(child)
            elif child.tag == "integrator":
                self.integrator(child)
            elif child.tag == "shape" and child.type == "shapegroup":
                self.shape_group(child)
            elif child.tag == "shape" and child.type == "instance":
                self.instance(child)
            elif child.tag == "shape":
                self.shape(child)
            elif child.tag == "texture" and child.id is not None:
                if child.type not in TEXTURES:  # checked here; all are read where referred to
                    self.constant_texture(child, False, True)
            elif child.tag == "emitter":
                self.emitter(child)
            elif child.tag == "bsdf":
                if child.id is None:
                    self.r.fail(child.path, "a <bsdf> in <scene> needs an id (shapes refer to it)")
            else:
                self.r.fail(child.path, f"<{child.tag}> is not supported (drtlab has no "
                                        f"{'media' if child.tag in ('medium', 'phase', 'volume') else child.tag + 's'})")
        if len(sensors) != 1:
            self.r.fail(root.path, f"exactly one <sensor> is needed, got {len(sensors)}")
        self.data.setdefault("scene", {}).setdefault("integrator", "path")
        if not self.integrated:         # no <integrator>: Mitsuba's default path
            self.data["scene"].update(max_depth=-1, russian_roulette=True, rr_depth=5)
        self.sensor(sensors[0])
        self.data["scene"]["description"] = "; ".join([f"Mitsuba 3 scene {self.r.file}"] + self.notes)
        return self.data

    def integrator(self, o: Obj) -> None:
        if o.type in WRAPPERS:
            inner = self.nested(o)
            if len(inner) != 1 or inner[0].tag != "integrator":
                self.r.fail(o.path, f"a {o.type} integrator wraps exactly one <integrator>")
            self.done(o)
            return self.integrator(inner[0])
        kind = self.kind(o, INTEGRATORS)
        if self.get(o, "hide_emitters", ("boolean",), False):
            self.r.fail(o.props["hide_emitters"].path, "true is not supported (drtlab always shows emitters)")
        s = self.data.setdefault("scene", {})
        if self.integrated:
            self.r.fail(o.path, "a second <integrator>")
        self.integrated = True
        s["integrator"] = "path"
        if kind == "ptracer":
            self.notes.append("its ptracer renders with path (the same image in expectation)")
        if kind == "direct":
            shading = self.number(o, "shading_samples", 1, lambda n: n == int(n) and n >= 1, "an integer >= 1")
            counts = {name: int(self.number(o, name, shading, lambda n: n == int(n) and n >= 0,
                                            "an integer >= 0"))
                      for name in ("emitter_samples", "bsdf_samples")}
            s.update(integrator="direct", **counts)
        else:
            depth = self.number(o, "max_depth", -1, lambda n: n == -1 or n >= 1, "-1 or >= 1")
            rr = self.number(o, "rr_depth", 5, lambda n: n >= 0, ">= 0")
            s["max_depth"] = int(depth)
            # Both roll with the index k of a path vertex (first hit 0) once k >= rr_depth: Mitsuba
            # before tracing to vertex k, drtlab at vertex k after its emission (the same unbiased
            # estimate, another split of the noise). No vertex k >= max_depth: no roulette.
            if depth == -1 or rr < depth:
                s.update(russian_roulette=True, rr_depth=max(int(rr), 1))
        self.ignore(o, "samples_per_pass", "timeout", "block_size")
        self.done(o)

    def sensor(self, o: Obj) -> None:
        kind = self.kind(o, SENSORS)
        film = sampler = None
        for child in self.nested(o):
            if child.tag == "film" and film is None:
                film = child
            elif child.tag == "sampler" and sampler is None:
                sampler = child
            else:
                self.r.fail(child.path, f"<{child.tag}> in a sensor is not supported")
        # No film: Mitsuba's default hdrfilm, 768 x 576 with its Gaussian and no border samples.
        width, height, film_filter = (self.film(film) if film else
                                      (768, 576, {"filter": MITSUBA_GAUSSIAN, "filter_clip": True}))
        s = self.data["scene"]
        s["resolution"] = [width, height]
        s["spp"] = self.sampler(sampler) if sampler else 4
        cam: dict = {}
        chain = self.get(o, "to_world", ("transform",), [])
        if kind == "orthographic":
            self.orthographic_frame(o, chain, width / height, cam)
        else:
            self.camera_frame(o, chain, cam)
            cam["fov"] = self.vertical_fov(o, width / height)
        cam.update(film_filter)
        self.ignore(o, "near_clip", "far_clip", "shutter_open", "shutter_close", "shutter_open_time")
        if kind == "thinlens":
            if "aperture_radius" not in o.props:
                self.r.fail(o.path, "thinlens needs aperture_radius")
            cam["aperture_radius"] = self.number(o, "aperture_radius", 0, lambda x: x >= 0, ">= 0")
            # Mitsuba's ProjectiveCamera: the focus is at the far clip plane unless given.
            far = self.number(o, "far_clip", 1e4, lambda x: x > 0, "> 0")
            cam["focus_distance"] = self.number(o, "focus_distance", far, lambda x: x > 0, "> 0")
        else:
            self.ignore(o, "focus_distance")
        for name in ("principal_point_offset_x", "principal_point_offset_y"):
            self.number(o, name, 0, lambda x: x == 0, "0 (drtlab's principal point is the centre)")
        self.data["camera"] = cam
        self.done(o)

    def camera_frame(self, o: Obj, chain, cam: dict) -> None:
        if len(chain) == 1 and chain[0][0] == "lookat":
            origin, target, up = chain[0][2]
            cam.update(position=list(origin), look_at=list(target), up=list(up))
            return
        m = chain_matrix(chain)
        a = m[:3, :3]
        lengths = np.linalg.norm(a, axis=0)
        gram = a.T @ a / lengths.max() ** 2
        if np.linalg.det(a) <= 0 or not np.allclose(gram, np.eye(3), atol=1e-6):
            self.r.fail(o.props["to_world"].path if chain else o.path,
                        "the camera's to_world must be a rotation and translation (with a uniform "
                        "scale): drtlab cannot mirror or shear the view")
        position = m[:3, 3]
        cam.update(position=position.tolist(), look_at=(position + a[:, 2]).tolist(),
                   up=(a[:, 1] / lengths[1]).tolist())

    def orthographic_frame(self, o: Obj, chain, aspect: float, cam: dict) -> None:
        """Mitsuba's orthographic sensor: rays along to_world's z from the film, which spans
        [-1, 1] x [-1 / aspect, 1 / aspect] in camera x, y at z = near_clip (orthographic_projection
        in include/mitsuba/render/sensor.h), through to_world. drtlab's film has square pixels: the
        x and y scales must be equal."""
        m = chain_matrix(chain)
        a = m[:3, :3]
        lengths = np.linalg.norm(a, axis=0)
        unit = a / lengths
        if (np.linalg.det(a) <= 0 or not np.allclose(unit.T @ unit, np.eye(3), atol=1e-9)
                or not math.isclose(lengths[0], lengths[1], rel_tol=1e-9)):
            self.r.fail(o.props["to_world"].path if chain else o.path,
                        "an orthographic camera's to_world must be a rotation and translation with "
                        "an equal x and y scale (square pixels): drtlab cannot mirror, shear or "
                        "stretch the view")
        near = self.number(o, "near_clip", NEAR_CLIP, lambda x: x > 0, "> 0")
        position = m[:3, :3] @ [0.0, 0.0, near] + m[:3, 3]
        cam.update(position=position.tolist(), look_at=(position + unit[:, 2]).tolist(),
                   up=unit[:, 1].tolist(), ortho_height=float(2.0 * lengths[1] / aspect))

    def vertical_fov(self, o: Obj, aspect: float) -> float:
        """parse_fov of src/render/sensor.cpp, turned into drtlab's full vertical fov."""
        fov, axis = self.fov_along(o)
        if resolved_axis(axis, aspect) == "y":
            return fov
        return math.degrees(2.0 * math.atan(math.tan(0.5 * math.radians(fov_x(fov, axis, aspect))) / aspect))

    def fov_along(self, o: Obj) -> tuple[float, str]:
        """(fov in degrees, the axis it spans) of a sensor or projector: `fov` and `fov_axis`, else
        its `focal_length` (50mm by default) along the diagonal (parse_fov)."""
        if "fov" in o.props and "focal_length" in o.props:
            self.r.fail(o.path, "give either fov or focal_length, not both")
        if "fov" in o.props:
            fov = self.number(o, "fov", None, lambda x: 0 < x < 180, "in (0, 180) degrees")
            return fov, self.string(o, "fov_axis", "x", FOV_AXES)
        text = self.string(o, "focal_length", "50mm")
        self.ignore(o, "fov_axis")          # parse_fov reads it with a fov only
        try:
            f = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            self.r.fail(o.props["focal_length"].path, f"must be like 50mm, got {text!r}")
        if not (math.isfinite(f) and f > 0):
            self.r.fail(o.props["focal_length"].path, f"must be a positive length, got {text!r}")
        return focal_length_fov(f), "diagonal"

    def film(self, o: Obj) -> tuple[int, int, dict]:
        """(width, height, the camera's filter keys) of an hdrfilm."""
        self.kind(o, ("hdrfilm",))
        size = [int(self.number(o, k, d, lambda n: n == int(n) and n >= 1, "an integer >= 1"))
                for k, d in (("width", 768), ("height", 576))]
        for k, full in (("crop_width", size[0]), ("crop_height", size[1]), ("crop_offset_x", 0),
                        ("crop_offset_y", 0)):
            self.number(o, k, full, lambda n, full=full: n == full, f"{full} (drtlab renders the whole film)")
        self.ignore(o, "file_format", "pixel_format", "component_format", "banner")
        # Mitsuba samples only the film unless sample_border: a pixel near the edge then weighs the
        # samples inside the film alone, its filter cut there (drtlab's filter_clip).
        border = self.get(o, "sample_border", ("boolean",), False)
        filters = self.nested(o)
        # No <rfilter>: Mitsuba's default, its Gaussian of stddev 0.5.
        cam = {"filter": MITSUBA_GAUSSIAN}
        for f in filters:
            if f.tag != "rfilter":
                self.r.fail(f.path, f"<{f.tag}> in a film is not supported")
            kind = self.kind(f, ("box", "gaussian", "mitchell"))
            if kind == "box":
                cam = {}
            elif kind == "gaussian":
                stddev = self.number(f, "stddev", MITSUBA_STDDEV, lambda x: STDDEV_MIN <= x <= STDDEV_MAX,
                                     f"in [{STDDEV_MIN}, {STDDEV_MAX}] pixels")
                cam = {"filter": MITSUBA_GAUSSIAN}
                if stddev != MITSUBA_STDDEV:
                    cam["filter_stddev"] = float(stddev)
            else:
                # Mitsuba splats each sample over radius 2, normalised by the weights: drtlab's
                # mitchell (B = C = 1/3).
                for name in ("B", "C"):
                    self.number(f, name, 1 / 3, lambda x: abs(x - 1 / 3) < 1e-6, "1/3 (drtlab's mitchell)")
                cam = {"filter": "mitchell"}
            self.done(f)
        if cam and not border:
            cam["filter_clip"] = True
        self.done(o)
        return size[0], size[1], cam

    def sampler(self, o: Obj) -> int:
        self.kind(o, SAMPLERS)
        spp = self.number(o, "sample_count", 4, lambda n: n == int(n) and n >= 1, "an integer >= 1")
        self.ignore(o, "seed", "jitter", "scramble")        # a drtlab sampler is a render setting
        self.done(o)
        return int(spp)
