"""In-memory scene model: what the loader (`scene_file.py`) produces and `scene_upload.upload` copies.

All geometry is in world space (the loader applies each shape's `transform`), float64 numpy arrays
of shape (3,). Boxes are expanded by the loader into six quads with outward normals (and sphere grids
into spheres), so the tracer only knows spheres, quads and triangle meshes.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from drtlab.kernels.scene_model.environment_map import EnvironmentMap
from drtlab.kernels.scene_model.texture import Texture

INTEGRATORS = ("whitted", "drt", "path", "direct")


@dataclass
class Camera:
    position: np.ndarray
    look_at: np.ndarray
    up: np.ndarray
    vfov_deg: float                     # full vertical field of view
    aperture_radius: float = 0.0        # 0 -> pinhole
    focus_distance: float = 1.0         # distance along the view axis of the plane in focus (> 0:
                                        # the kernels divide by it, pinhole or not)
    shutter: tuple[float, float] = (0.0, 0.0)
    filter: str = "box"                 # pixel reconstruction filter, a name in kernels/filters.py
    filter_stddev: float = 0.0          # its stddev (filters.STDDEV_FILTERS); 0: the filter's default
    filter_clip: bool = False           # the filter truncated to the film (no samples beyond its edge)
    ortho_height: float = 0.0           # > 0: an orthographic camera, rays along the view axis from a
                                        # film this high (world units) at position; 0: perspective

    def __post_init__(self):
        if not self.focus_distance > 0.0:
            raise ValueError(f"Camera.focus_distance must be > 0, got {self.focus_distance}")

    @property
    def has_lens(self) -> bool:
        return self.aperture_radius > 0.0

    @property
    def orthographic(self) -> bool:
        return self.ortho_height > 0.0


@dataclass
class Material:
    name: str
    kind: str                                   # one of material_kinds.MATERIAL_KINDS
    albedo: np.ndarray = field(default_factory=lambda: np.full(3, 0.5))
    # second checker colour (diffuse/glossy/plastic), or a diffuse's albedo where its "weight"
    # texture is 1 (TOML blend_albedo)
    albedo2: np.ndarray | None = None
    checker: tuple[int, int] | None = None      # checks along the shape's (u, v) parameters
    # Parameters read from a texture at the hit's uv, by slot (texture.TEXTURE_SLOTS: "albedo", ...;
    # the scene-file key is texture.slot_key(slot))
    textures: dict[str, Texture] = field(default_factory=dict)
    bump_scale: float = 1.0                     # the "bump" texture's height scale (Mitsuba's `scale`)
    exponent: float = 0.0                       # modified-Phong exponent (glossy, glossy_dielectric,
                                                # plastic's coat)
    roughness: float = 0.1                      # GGX alpha (ggx, ggx_dielectric), in
                                                # [material_kinds.ROUGHNESS_MIN, 1]
    alpha_u: float = 0.1                        # an anisotropic kind's alpha along the tangent dp/du
    alpha_v: float = 0.1                        # ... and across it (same range as roughness)
    ior: float = 1.5                            # dielectric, glossy_dielectric, plastic's coat
                                                # (outside is vacuum)
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))  # emitted radiance
    # A conductor's complex index of refraction eta + i k per channel (conductor kinds); the
    # default, 0 + 1i, reflects everything at every angle (Mitsuba's material "none").
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))
    k: np.ndarray = field(default_factory=lambda: np.ones(3))
    # Mitsuba 3's `mask` around the material (kernels/materials/mask.py): the share of hits that
    # scatter by the kind, the rest passing straight through; 1 is an ordinary surface.
    opacity: float = 1.0
    # Black from behind (Mitsuba's diffuse, conductors and plastics unless `twosided`); a kind
    # that does not transmit only
    one_sided: bool = False
    # A `params` kind's parameters by name (principled_params.py; the kind's defaults where absent)
    params: dict[str, float] = field(default_factory=dict)

    @property
    def emissive(self) -> bool:
        return bool(np.any(self.emission > 0.0))


@dataclass
class TriangleMesh:
    """A triangle mesh in world space (kernels/scene_model/mesh_file.py loads and validates it): the front of a
    triangle (a, b, c) is the side of (b - a) x (c - a), which is also the side an emitter lights."""
    vertices: np.ndarray                        # (V, 3) float64
    faces: np.ndarray                           # (F, 3) int32 vertex indices
    normals: np.ndarray | None = None           # (V, 3) unit vertex normals (smooth shading), or None
    # (V, 2) texture coordinates as Mitsuba reads an OBJ's (u, 1 - v: flip_tex_coords), or None
    uvs: np.ndarray | None = None
    source: str = ""                            # the file or generator it came from
    # A PLY file's vertex and face attributes by Mitsuba's name (mesh_attributes.py): "vertex_..."
    # (V, channels) and "face_..." (F, channels) float32
    attributes: dict[str, np.ndarray] = field(default_factory=dict)

    def triangle_areas(self) -> np.ndarray:
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)

    def digest(self) -> str:
        """Hash of the geometry: what a scene's content_hash cannot see in its TOML text."""
        h = hashlib.sha256(np.ascontiguousarray(self.vertices).tobytes())
        h.update(np.ascontiguousarray(self.faces).tobytes())
        if self.normals is not None:
            h.update(np.ascontiguousarray(self.normals).tobytes())
        if self.uvs is not None:
            h.update(np.ascontiguousarray(self.uvs).tobytes())
        for name in sorted(self.attributes):
            h.update(name.encode() + np.ascontiguousarray(self.attributes[name]).tobytes())
        return h.hexdigest()


@dataclass
class Shape:
    kind: str                                   # "sphere" | "quad" | "mesh"
    material: int                               # index into Scene.materials
    name: str = ""
    center: np.ndarray | None = None            # sphere
    radius: float = 0.0                         # sphere
    # sphere: world directions -> its own frame (its transform's rotation, transposed), which only a
    # texture reads (Mitsuba's uv); None: the world's axes.
    to_local: np.ndarray | None = None
    origin: np.ndarray | None = None            # quad: corner
    edge_u: np.ndarray | None = None            # quad: first edge; normal = normalize(edge_u x edge_v)
    edge_v: np.ndarray | None = None            # quad: second edge
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))  # world units per unit time
    mesh: TriangleMesh | None = None            # mesh: its triangles (moving rigidly with velocity)

    def area(self) -> float:
        if self.kind == "sphere":
            return 4.0 * np.pi * self.radius ** 2
        if self.kind == "mesh":
            return float(np.sum(self.mesh.triangle_areas()))
        return float(np.linalg.norm(np.cross(self.edge_u, self.edge_v)))


# Mitsuba 3's spot defaults (src/emitters/spot.cpp): a 20 degree cutoff, a beam of 3/4 of it.
SPOT_CUTOFF_DEFAULT = 20.0
SPOT_BEAM_SHARE = 0.75


@dataclass
class PointLight:
    position: np.ndarray
    intensity: np.ndarray                       # W/sr per channel (a spot's: on its axis)
    # A spot (Mitsuba 3's): its axis as given (any length; the TOML direction or look_at - position),
    # None for a point light; its cone in degrees, Mitsuba's falloff (kernels/spot.py).
    direction: np.ndarray | None = None
    cutoff_angle: float = 0.0
    beam_width: float = 0.0
    # A projection (kernels/scene_model/light_projection.py): the frame's up (a spot's with a texture,
    # a projector's), a spot's projected texture or a projector's irradiance texture, and a
    # projector's horizontal field of view in degrees (0: not a projector; then `direction` is its
    # axis and `intensity` its scale x irradiance).
    up: np.ndarray | None = None
    texture: Texture | None = None
    fov_x: float = 0.0

    @property
    def projector(self) -> bool:
        return self.fov_x > 0.0

    @property
    def spot(self) -> bool:
        return self.direction is not None and not self.projector

    @property
    def projects(self) -> bool:
        """A projector or a spot with a texture: the kernels' projection (kernels/projection.py)."""
        return self.projector or self.texture is not None


@dataclass
class DirectionalLight:
    direction: np.ndarray                       # unit vector the light travels along
    irradiance: np.ndarray                      # on a surface facing the light


@dataclass
class Scene:
    name: str
    description: str
    width: int
    height: int
    spp: int
    integrator: str                             # default integrator, one of INTEGRATORS
    max_depth: int                              # Mitsuba 3 convention: 1 = emitters seen directly only
    rr_depth: int                               # Russian roulette starts at this depth (path only)
    russian_roulette: bool
    background: np.ndarray                      # radiance of escaping rays
    camera: Camera
    materials: list[Material]
    shapes: list[Shape]
    point_lights: list[PointLight] = field(default_factory=list)
    directional_lights: list[DirectionalLight] = field(default_factory=list)
    environment: EnvironmentMap | None = None   # the [environment] light (kernels/scene_model/environment_map.py)
    emitter_samples: int = 1                    # integrator "direct" (Mitsuba 3's): light samples at the hit
    bsdf_samples: int = 1                       # ... and BSDF samples
    source: str = ""                            # built-in name or file path
    text: str = ""                              # the TOML text the scene came from

    def content_hash(self) -> str:
        """Hash of what determines the image: the TOML text (with its overrides, which the loader
        appends) and the fields code may replace afterwards (resolution, depth, roulette)."""
        h = hashlib.sha256(self.text.encode())
        h.update(repr((self.width, self.height, self.integrator, self.max_depth, self.rr_depth,
                       self.russian_roulette)).encode())
        if (self.emitter_samples, self.bsdf_samples) != (1, 1):    # the defaults keep older hashes
            h.update(repr((self.emitter_samples, self.bsdf_samples)).encode())
        for s in self.shapes:           # a mesh file may change under an unchanged TOML text
            if s.mesh is not None:
                h.update(s.mesh.digest().encode())
        for m in self.materials:        # and a texture's image file
            for slot in sorted(m.textures):
                h.update(m.textures[slot].digest().encode())
        for pl in self.point_lights:
            if pl.texture is not None:
                h.update(pl.texture.digest().encode())
        if self.environment is not None:        # so may an environment's image file
            h.update(self.environment.digest().encode())
        return h.hexdigest()[:16]

    @property
    def has_motion(self) -> bool:
        return self.camera.shutter[1] > self.camera.shutter[0] and any(
            np.any(s.velocity != 0.0) for s in self.shapes)

    def emitter_shapes(self) -> list[int]:
        return [i for i, s in enumerate(self.shapes) if self.materials[s.material].emissive]
