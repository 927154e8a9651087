"""The device copy of the scene: the SceneData struct the kernels read, and `upload` that fills it.

Besides the model's values it holds what kernels/intersection/quad_records.py derives once per scene for the ray tests
(quad records, box groups) and what kernels/intersection/bvh_build.py builds (a wp.Bvh of its triangles' boxes
per triangle mesh, one over many spheres, the mesh tables). Uploads of equal contents reuse the same
device arrays (the kernels only read them), so the many renders of one scene in a study pay the
upload once."""
import hashlib
import math
import os
import pickle
import threading
from collections import OrderedDict
from collections.abc import Callable
from functools import partial

import numpy as np
import warp as wp

from drtlab.kernels.intersection.quad_records import quad_geometry, quad_groups
from drtlab.kernels.colour import luminance
from drtlab.kernels.features import material_kinds, splits_for, uses_sphere_bvh
from drtlab.kernels.intersection.primitives import QuadGeom
from drtlab.kernels.intersection.bvh_build import build_bvh, mesh_tables, sphere_boxes
from drtlab.kernels.material_kinds import MATERIAL_CODE
from drtlab.kernels.scene import Scene
from drtlab.warp_runtime import warp as initialised_warp

# Shape kinds (Hit.kind, SceneData.light_shape_kind).
SPHERE = wp.constant(0)
QUAD = wp.constant(1)
MESH = wp.constant(2)           # Hit.index: the face's index in the per-face arrays (tri_*)


@wp.struct
class SceneData:
    sph_center: wp.array(dtype=wp.vec3)
    sph_radius: wp.array(dtype=float)
    sph_velocity: wp.array(dtype=wp.vec3)
    sph_material: wp.array(dtype=int)
    sph_light: wp.array(dtype=int)
    n_spheres: int
    quad_origin: wp.array(dtype=wp.vec3)
    quad_u: wp.array(dtype=wp.vec3)
    quad_v: wp.array(dtype=wp.vec3)
    quad_normal: wp.array(dtype=wp.vec3)
    quad_geom: wp.array(dtype=QuadGeom)        # what the ray tests read (accel.quad_geometry)
    quad_area: wp.array(dtype=float)
    quad_velocity: wp.array(dtype=wp.vec3)
    quad_material: wp.array(dtype=int)
    quad_light: wp.array(dtype=int)
    n_quads: int
    # The quads as groups in index order (accel.quad_groups): single quads and boxes.
    qgroup_quad: wp.array(dtype=int)           # a single quad's index, -1 for a box
    qgroup_corner: wp.array(dtype=wp.vec3)
    qgroup_inverse: wp.array(dtype=wp.mat33)
    qgroup_aligned: wp.array(dtype=int)        # box: 1 if axis-aligned (inverse diagonal)
    qgroup_ball: wp.array(dtype=wp.vec4)       # closed box: a ball around it; radius < 0: none
    qgroup_velocity: wp.array(dtype=wp.vec3)
    qgroup_rank: wp.array(dtype=int)
    qgroup_faces: wp.array(dtype=int)          # 6 per group: quad index by face slot, -1 none
    quad_group: wp.array(dtype=int)
    n_qgroups: int
    # Triangle meshes (kernels/intersection/bvh_build.py), vertices at shutter open: per mesh a wp.Bvh of its
    # triangles' boxes (item k: the mesh's face k).
    mesh_bvh: wp.array(dtype=wp.uint64)
    mesh_face0: wp.array(dtype=int)            # n_meshes + 1 offsets into the per-face arrays
    mesh_velocity: wp.array(dtype=wp.vec3)
    mesh_material: wp.array(dtype=int)
    mesh_light: wp.array(dtype=int)
    mesh_smooth: wp.array(dtype=int)           # 1: shading normals interpolated from vert_normal
    mesh_area: wp.array(dtype=float)
    mesh_centroid: wp.array(dtype=wp.vec3)     # Whitted's point-light stand-in
    mesh_normal_area: wp.array(dtype=wp.vec3)  # sum over faces of area * unit normal
    n_meshes: int
    tri_index: wp.array(dtype=wp.vec3i)        # per face: its vertices in mesh_points
    tri_cdf: wp.array(dtype=float)             # per face: area cdf within its mesh
    tri_mesh: wp.array(dtype=int)              # per face: its mesh
    mesh_points: wp.array(dtype=wp.vec3)       # every mesh's vertices
    vert_normal: wp.array(dtype=wp.vec3)       # per vertex (zeros in flat meshes)
    sph_bvh: wp.uint64                         # wp.Bvh over the spheres' swept boxes; 0: none
    mat_kind: wp.array(dtype=int)
    mat_albedo: wp.array(dtype=wp.vec3)
    mat_albedo2: wp.array(dtype=wp.vec3)
    mat_checker: wp.array(dtype=wp.vec2)
    mat_exponent: wp.array(dtype=float)
    mat_ior: wp.array(dtype=float)
    mat_emission: wp.array(dtype=wp.vec3)
    light_shape_kind: wp.array(dtype=int)
    light_shape: wp.array(dtype=int)
    light_pmf: wp.array(dtype=float)
    light_cdf: wp.array(dtype=float)
    n_lights: int
    pl_position: wp.array(dtype=wp.vec3)
    pl_intensity: wp.array(dtype=wp.vec3)
    n_point_lights: int
    dl_direction: wp.array(dtype=wp.vec3)
    dl_irradiance: wp.array(dtype=wp.vec3)
    n_dir_lights: int
    background: wp.vec3
    eps: float
    cam_position: wp.vec3
    cam_right: wp.vec3
    cam_up: wp.vec3
    cam_forward: wp.vec3
    half_width: float
    half_height: float
    aperture: float
    focus_distance: float
    shutter_open: float
    shutter_close: float
    width: int
    height: int
    max_depth: int
    rr_depth: int
    whitted_codes: int
    moving: int                 # 1: shapes move within the shutter (intersect.make_motion)


def _f3(v) -> tuple:
    return tuple(float(x) for x in np.asarray(v, dtype=np.float64).reshape(3))


def scene_extent(scene: Scene) -> float:
    """Diagonal of the box around the camera and every shape: the scale of the BVH boxes' padding,
    public because bench/primitives.py times the BVH builds alone with the same padding."""
    pts = [scene.camera.position]
    for s in scene.shapes:
        if s.kind == "sphere":
            pts += [s.center - s.radius, s.center + s.radius]
        elif s.kind == "mesh":      # as uploaded, at shutter open (like its wp.Mesh)
            v = _at_time(s.mesh.vertices, s.velocity, float(scene.camera.shutter[0]))
            pts += [v.min(axis=0), v.max(axis=0)]
        else:
            pts += [s.origin, s.origin + s.edge_u + s.edge_v, s.origin + s.edge_u,
                    s.origin + s.edge_v]
    pts = np.array(pts, dtype=np.float64)
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0))) or 1.0


# Device arrays by content: renders of one scene (a convergence study's many runs) upload the same
# values again and again; the kernels only read these arrays, so equal contents can share one.
_ARRAYS: OrderedDict = OrderedDict()
_ARRAYS_MAX = 1024
_arrays_lock = threading.Lock()


def _after_fork_in_child() -> None:
    global _arrays_lock
    _arrays_lock = threading.Lock()      # a forked child may inherit it held by another thread


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def _cached(key, make: Callable):
    """The cached value for `key`, made (and the oldest dropped past _ARRAYS_MAX) when missing."""
    with _arrays_lock:
        value = _ARRAYS.get(key)
        if value is not None:
            _ARRAYS.move_to_end(key)
            return value
    value = make()
    with _arrays_lock:
        _ARRAYS[key] = value
        while len(_ARRAYS) > _ARRAYS_MAX:
            _ARRAYS.popitem(last=False)
    return value


def _device_array(values, dtype, empty_shape, device: str):
    """`values` as a Warp array on `device`; an empty list becomes zeros of `empty_shape`."""
    a = np.asarray(values, dtype=np.int32 if dtype in (int, wp.vec3i) else np.float32)
    if a.size == 0:
        a = np.zeros(empty_shape, dtype=a.dtype)
    a = np.ascontiguousarray(a)
    key = ("array", device, str(dtype), a.dtype.str, a.shape, a.tobytes())
    return _cached(key, lambda: wp.array(a, dtype=dtype, device=device))


def _put_shapes(sd: SceneData, scene: Scene, spheres: list, quads: list, arr: Callable,
                device: str) -> None:
    light_of = {id(scene.shapes[i]): li for li, i in enumerate(scene.emitter_shapes())}
    # Shapes move as c + v t in absolute shutter time; the kernels add v (t - open), so the uploaded
    # positions are those at shutter open (also what a static render, whitted or a closed shutter, shows).
    t_open = float(scene.camera.shutter[0])
    sd.sph_center = arr([_at_time(s.center, s.velocity, t_open) for s in spheres], wp.vec3, (1, 3))
    sd.sph_radius = arr([s.radius for s in spheres], float, (1,))
    sd.sph_velocity = arr([s.velocity for s in spheres], wp.vec3, (1, 3))
    sd.sph_material = arr([s.material for s in spheres], int, (1,))
    sd.sph_light = arr([light_of.get(id(s), -1) for s in spheres], int, (1,))
    sd.n_spheres = len(spheres)
    sd.quad_origin = arr([_at_time(s.origin, s.velocity, t_open) for s in quads], wp.vec3, (1, 3))
    sd.quad_u = arr([s.edge_u for s in quads], wp.vec3, (1, 3))
    sd.quad_v = arr([s.edge_v for s in quads], wp.vec3, (1, 3))
    normals = np.cross(np.array([s.edge_u for s in quads], dtype=np.float64).reshape(-1, 3),
                       np.array([s.edge_v for s in quads], dtype=np.float64).reshape(-1, 3))
    areas = np.linalg.norm(normals, axis=1)
    sd.quad_normal = arr(normals / areas[:, None] if quads else [], wp.vec3, (1, 3))
    sd.quad_area = arr(areas, float, (1,))
    sd.quad_velocity = arr([s.velocity for s in quads], wp.vec3, (1, 3))
    sd.quad_material = arr([s.material for s in quads], int, (1,))
    sd.quad_light = arr([light_of.get(id(s), -1) for s in quads], int, (1,))
    sd.n_quads = len(quads)
    # Keyed by the (cached, so alive and unique) input arrays themselves.
    inputs = (sd.quad_origin, sd.quad_u, sd.quad_v)
    sd.quad_geom = _cached(("geom", *map(id, inputs)),
                           lambda: (quad_geometry(*inputs, device), inputs))[0]
    groups = _cached(("groups", t_open, np.array([[s.origin, s.edge_u, s.edge_v, s.velocity]
                                                  for s in quads], dtype=np.float64).tobytes()),
                     lambda: quad_groups(quads, t_open))
    sd.qgroup_quad = arr(groups.quad, int, (1,))
    sd.qgroup_corner = arr(groups.corner, wp.vec3, (1, 3))
    sd.qgroup_inverse = arr(groups.inverse, wp.mat33, (1, 3, 3))
    sd.qgroup_ball = arr(groups.ball, wp.vec4, (1, 4))
    sd.qgroup_aligned = arr([int(np.count_nonzero(m - np.diag(np.diag(m))) == 0)
                             for m in groups.inverse], int, (1,))
    sd.qgroup_velocity = arr(groups.velocity, wp.vec3, (1, 3))
    sd.qgroup_rank = arr(groups.rank, int, (1,))
    sd.qgroup_faces = arr(groups.faces, int, (1,))
    sd.quad_group = arr(groups.group_of, int, (1,))
    sd.n_qgroups = len(groups.quad)


def _put_materials(sd: SceneData, materials: list, arr: Callable) -> None:
    sd.mat_kind = arr([MATERIAL_CODE[m.kind] for m in materials], int, (1,))
    sd.mat_albedo = arr([m.albedo for m in materials], wp.vec3, (1, 3))
    sd.mat_albedo2 = arr([m.albedo2 if m.albedo2 is not None else m.albedo for m in materials],
                         wp.vec3, (1, 3))
    sd.mat_checker = arr([m.checker if m.checker is not None else (0, 0) for m in materials],
                         wp.vec2, (1, 2))
    sd.mat_exponent = arr([m.exponent for m in materials], float, (1,))
    sd.mat_ior = arr([m.ior for m in materials], float, (1,))
    sd.mat_emission = arr([m.emission for m in materials], wp.vec3, (1, 3))


def _put_lights(sd: SceneData, scene: Scene, spheres: list, quads: list, meshes: list,
                arr: Callable) -> None:
    """Area lights (emitting shapes, picked by power or uniformly), point and directional lights."""
    index = {id(s): i for group in (spheres, quads, meshes) for i, s in enumerate(group)}
    code = {"sphere": SPHERE, "quad": QUAD, "mesh": MESH}
    emitters = [scene.shapes[i] for i in scene.emitter_shapes()]
    power = [max(luminance(scene.materials[s.material].emission), 1e-12) * s.area() * math.pi
             for s in emitters]
    pmf = np.array(power) / np.sum(power) if power else np.zeros(0)
    cdf = np.cumsum(pmf) if power else np.zeros(0)
    sd.light_shape_kind = arr([code[s.kind] for s in emitters], int, (1,))
    sd.light_shape = arr([index[id(s)] for s in emitters], int, (1,))
    sd.light_pmf = arr(pmf, float, (1,))
    sd.light_cdf = arr(cdf, float, (1,))
    sd.n_lights = len(emitters)
    points, dirs = scene.point_lights, scene.directional_lights
    sd.pl_position = arr([pl.position for pl in points], wp.vec3, (1, 3))
    sd.pl_intensity = arr([pl.intensity for pl in points], wp.vec3, (1, 3))
    sd.n_point_lights = len(points)
    sd.dl_direction = arr([dl.direction for dl in dirs], wp.vec3, (1, 3))
    sd.dl_irradiance = arr([dl.irradiance for dl in dirs], wp.vec3, (1, 3))
    sd.n_dir_lights = len(dirs)


def camera_basis(cam) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(position, forward, right, up) of a camera, float64 unit vectors: the frame the kernels'
    camera rays are built in."""
    pos = np.asarray(cam.position, dtype=np.float64)
    fwd = np.asarray(cam.look_at, dtype=np.float64) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(cam.up, dtype=np.float64))
    right /= np.linalg.norm(right)
    return pos, fwd, right, np.cross(right, fwd)


def _put_camera(sd: SceneData, scene: Scene) -> None:
    cam = scene.camera
    pos, fwd, right, up = camera_basis(cam)
    sd.cam_position = wp.vec3(*_f3(pos))
    sd.cam_right = wp.vec3(*_f3(right))
    sd.cam_up = wp.vec3(*_f3(up))
    sd.cam_forward = wp.vec3(*_f3(fwd))
    half_h = math.tan(math.radians(cam.vfov_deg) / 2)
    sd.half_height = float(half_h)
    sd.half_width = float(half_h * scene.width / scene.height)
    sd.aperture = float(cam.aperture_radius)
    sd.focus_distance = float(cam.focus_distance if cam.focus_distance > 0 else 1.0)
    sd.shutter_open = float(cam.shutter[0])
    sd.shutter_close = float(cam.shutter[1])


def _put_meshes(sd: SceneData, scene: Scene, meshes: list, arr: Callable, device: str,
                extent: float) -> list:
    """The meshes' BVHs and tables; returns the wp.Bvh objects, which must outlive sd."""
    light_of = {id(scene.shapes[i]): li for li, i in enumerate(scene.emitter_shapes())}
    t_open = float(scene.camera.shutter[0])
    tables = mesh_tables(meshes, t_open, extent)
    built = [_cached(("bvh", device, lo.tobytes(), hi.tobytes()),
                     lambda lo=lo, hi=hi: build_bvh(lo, hi, device))
             for lo, hi in tables.boxes]
    sd.mesh_bvh = wp.array(np.array([b.id for b in built] or [0], dtype=np.uint64),
                           dtype=wp.uint64, device=device)
    sd.mesh_face0 = arr(tables.face0, int, (1,))
    sd.tri_index = arr(tables.tri_index, wp.vec3i, (1, 3))
    sd.mesh_points = arr(tables.points, wp.vec3, (1, 3))
    sd.mesh_velocity = arr([s.velocity for s in meshes], wp.vec3, (1, 3))
    sd.mesh_material = arr([s.material for s in meshes], int, (1,))
    sd.mesh_light = arr([light_of.get(id(s), -1) for s in meshes], int, (1,))
    sd.mesh_smooth = arr(tables.smooth, int, (1,))
    sd.mesh_area = arr(tables.area, float, (1,))
    sd.mesh_centroid = arr(tables.centroid, wp.vec3, (1, 3))
    sd.mesh_normal_area = arr(tables.normal_area, wp.vec3, (1, 3))
    sd.n_meshes = len(meshes)
    sd.tri_cdf = arr(tables.cdf, float, (1,))
    sd.tri_mesh = arr(tables.tri_mesh, int, (1,))
    sd.vert_normal = arr(tables.vert_normal, wp.vec3, (1, 3))
    return built


def _put_sphere_bvh(sd: SceneData, scene: Scene, spheres: list, device: str,
                    extent: float) -> list:
    """A wp.Bvh over the spheres when they are many (features.uses_sphere_bvh); returns it."""
    sd.sph_bvh = wp.uint64(0)
    if not uses_sphere_bvh(scene):
        return []
    lowers, uppers = sphere_boxes(spheres, *map(float, scene.camera.shutter), extent)
    bvh = _cached(("bvh", device, lowers.tobytes(), uppers.tobytes()),
                  lambda: build_bvh(lowers, uppers, device))
    sd.sph_bvh = wp.uint64(bvh.id)
    return [bvh]


def _at_time(position, velocity, t: float):
    """A shape's position at time t (unchanged, bit for bit, at t = 0)."""
    return position if t == 0.0 else position + velocity * t


def upload(scene: Scene, device: str) -> SceneData:
    """Pack a Scene into the kernels' SceneData struct (arrays on `device`), once per content: the
    kernels only read it, and a study renders one scene thousands of times (the pickle's digest costs
    ~0.3 ms against ~3 ms of packing a small scene)."""
    initialised_warp()
    digest = hashlib.blake2b(pickle.dumps(scene, protocol=5), digest_size=16).digest()
    # Besides the content, the packing reads the features' thresholds (tests move them).
    layout = (uses_sphere_bvh(scene), splits_for(material_kinds(scene)))
    return _cached(("scene", device, digest, layout), lambda: _upload(scene, device))


def _upload(scene: Scene, device: str) -> SceneData:
    arr = partial(_device_array, device=device)
    spheres = [s for s in scene.shapes if s.kind == "sphere"]
    quads = [s for s in scene.shapes if s.kind == "quad"]
    meshes = [s for s in scene.shapes if s.kind == "mesh"]
    sd = SceneData()
    _put_shapes(sd, scene, spheres, quads, arr, device)
    # SceneData holds only the ids of these; the objects ride along so that they outlive it (a
    # Warp struct takes no attributes of its own, hence __dict__).
    extent = scene_extent(scene)
    sd.__dict__["_accel"] = (_put_meshes(sd, scene, meshes, arr, device, extent)
                             + _put_sphere_bvh(sd, scene, spheres, device, extent))
    _put_materials(sd, scene.materials, arr)
    _put_lights(sd, scene, spheres, quads, meshes, arr)
    _put_camera(sd, scene)
    sd.background = wp.vec3(*_f3(scene.background))
    sd.eps = float(1e-6 * extent)
    sd.width = int(scene.width)
    sd.height = int(scene.height)
    sd.max_depth = int(scene.max_depth)
    sd.rr_depth = int(scene.rr_depth)
    # Whitted's reflect/refract choices, one bit per split (one code when nothing splits).
    sd.whitted_codes = 1 << splits_for(material_kinds(scene))
    sd.moving = int(scene.has_motion)
    return sd
