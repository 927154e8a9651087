"""`upload`: the scene model (kernels/scene_model/scene.py) copied into the SceneData the kernels read
(kernels/device_scene.py).

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
from dataclasses import fields
from functools import partial

import numpy as np
import warp as wp

from drtlab.kernels.intersection.quad_records import quad_geometry, quad_groups, vector_lanes
from drtlab.kernels.intersection.quad_simd import quad_pack
from drtlab.kernels.colour import luminance
from drtlab.kernels.environment import environment_data
from drtlab.kernels.features import material_kinds, splits_for, uses_quad_simd, uses_sphere_bvh
from drtlab.kernels.intersection.bvh_build import build_bvh, mesh_tables, sphere_boxes
from drtlab.kernels.filters import BOX, clip_table, filter_cdf, get_filter
from drtlab.kernels.materials.mesh_attribute import attribute_tables
from drtlab.kernels.materials.texture import texture_tables
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME, MATERIAL_CODE
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, CameraData, SceneData
from drtlab.kernels.scene_model.scene import Camera, Scene
from drtlab.kernels.projection import projection_row
from drtlab.kernels.scene_model.texture import texture_pool
from drtlab.kernels.spot import spot_axis, spot_cone
from drtlab.warp_runtime import warp as initialised_warp


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


def quad_grouping(quads: list, t_open: float):
    """quad_records.quad_groups of the scene's quads (cached by their geometry)."""
    return _cached(("groups", t_open, np.array([[s.origin, s.edge_u, s.edge_v, s.velocity]
                                                for s in quads], dtype=np.float64).tobytes()),
                   lambda: quad_groups(quads, t_open))


def uses_vector_quads(scene: Scene, device: str) -> bool:
    """Features.quad_simd of rendering `scene` on `device`: on the CPU, where the quads the vector
    test would hold (quad_records.vector_lanes) are as many as features.uses_quad_simd wants."""
    quads = [s for s in scene.shapes if s.kind == "quad"]
    if device != "cpu" or not quads:
        return False
    return uses_quad_simd(len(vector_lanes(quad_grouping(quads, float(scene.camera.shutter[0])))[0]))


def _device_array(values, dtype, empty_shape, device: str):
    """`values` as a Warp array on `device`; an empty list becomes zeros of `empty_shape`."""
    a = np.asarray(values, dtype=np.int32 if dtype in (int, wp.vec2i, wp.vec3i, wp.vec4i)
                   else np.float32)
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
    sp = sd.spheres
    sp.center = arr([_at_time(s.center, s.velocity, t_open) for s in spheres], wp.vec3, (1, 3))
    sp.radius = arr([s.radius for s in spheres], float, (1,))
    sp.velocity = arr([s.velocity for s in spheres], wp.vec3, (1, 3))
    sp.material = arr([s.material for s in spheres], int, (1,))
    sp.light = arr([light_of.get(id(s), -1) for s in spheres], int, (1,))
    sp.to_local = arr([np.eye(3) if s.to_local is None else s.to_local for s in spheres], wp.mat33,
                      (1, 3, 3))
    sp.count = len(spheres)
    q = sd.quads
    q.origin = arr([_at_time(s.origin, s.velocity, t_open) for s in quads], wp.vec3, (1, 3))
    q.u = arr([s.edge_u for s in quads], wp.vec3, (1, 3))
    q.v = arr([s.edge_v for s in quads], wp.vec3, (1, 3))
    normals = np.cross(np.array([s.edge_u for s in quads], dtype=np.float64).reshape(-1, 3),
                       np.array([s.edge_v for s in quads], dtype=np.float64).reshape(-1, 3))
    areas = np.linalg.norm(normals, axis=1)
    q.normal = arr(normals / areas[:, None] if quads else [], wp.vec3, (1, 3))
    q.area = arr(areas, float, (1,))
    q.velocity = arr([s.velocity for s in quads], wp.vec3, (1, 3))
    q.material = arr([s.material for s in quads], int, (1,))
    q.light = arr([light_of.get(id(s), -1) for s in quads], int, (1,))
    q.count = len(quads)
    # Keyed by the (cached, so alive and unique) input arrays themselves.
    inputs = (q.origin, q.u, q.v)
    q.geom = _cached(("geom", *map(id, inputs)),
                     lambda: (quad_geometry(*inputs, device), inputs))[0]
    groups = quad_grouping(quads, t_open)
    lanes, boxes = vector_lanes(groups)
    pack, q.blocks = quad_pack(lanes, *(np.array(rows, dtype=np.float64).reshape(-1, 3) for rows in (
        [_at_time(s.origin, s.velocity, t_open) for s in quads], [s.edge_u for s in quads],
        [s.edge_v for s in quads], [s.velocity for s in quads])))
    q.pack = arr(pack, float, (1,))
    q.lane = arr(np.isin(np.arange(len(quads)), lanes).astype(int), int, (1,))
    g = sd.quad_groups
    g.quad = arr(groups.quad, int, (1,))
    g.corner = arr(groups.corner, wp.vec3, (1, 3))
    g.inverse = arr(groups.inverse, wp.mat33, (1, 3, 3))
    g.ball = arr(groups.ball, wp.vec4, (1, 4))
    g.aligned = arr([int(np.count_nonzero(m - np.diag(np.diag(m))) == 0) for m in groups.inverse],
                    int, (1,))
    g.velocity = arr(groups.velocity, wp.vec3, (1, 3))
    g.rank = arr(groups.rank, int, (1,))
    g.faces = arr(groups.faces, int, (1,))
    g.count = len(groups.quad)
    g.box = arr(boxes, int, (1,))
    g.n_box = len(boxes)
    q.group = arr(groups.group_of, int, (1,))


def _put_materials(sd: SceneData, materials: list, arr: Callable, lights: list = ()) -> dict:
    """The materials and the texture pool (the lights' textures too); returns each pool texture's
    index by id."""
    m = sd.materials
    m.kind = arr([MATERIAL_CODE[x.kind] for x in materials], int, (1,))
    m.albedo = arr([x.albedo for x in materials], wp.vec3, (1, 3))
    m.albedo2 = arr([x.albedo2 if x.albedo2 is not None else x.albedo for x in materials],
                    wp.vec3, (1, 3))
    m.checker = arr([x.checker if x.checker is not None else (0, 0) for x in materials],
                    wp.vec2, (1, 2))
    m.shape = arr([KIND_BY_NAME[x.kind].shape(x) for x in materials], float, (1,))
    m.shape_v = arr([KIND_BY_NAME[x.kind].shape_v(x) for x in materials], float, (1,))
    m.ior = arr([x.ior for x in materials], float, (1,))
    m.emission = arr([x.emission for x in materials], wp.vec3, (1, 3))
    m.eta = arr([x.eta for x in materials], wp.vec3, (1, 3))
    m.k = arr([x.k for x in materials], wp.vec3, (1, 3))
    m.opacity = arr([x.opacity for x in materials], float, (1,))
    m.one_sided = arr([int(x.one_sided) for x in materials], int, (1,))
    rows, table = [], [np.zeros(1, dtype=np.float32)]
    for x in materials:
        spec = KIND_BY_NAME[x.kind]
        rows.append(sum(len(t) for t in table) if spec.table else 0)
        if spec.table:
            from drtlab.kernels.materials.kinds import model_module
            table.append(model_module(spec).table_row(x.kind, x.albedo, x.roughness, x.ior,
                                                      **({"params": x.params} if spec.params else {})))
    m.table = arr(np.concatenate(table), float, (1,))
    m.row = arr(rows, int, (1,))
    t = texture_tables(materials, lights)
    m.tex = arr(t["tex"], int, (1,))
    m.textured = arr(t["textured"], int, (1,))
    m.tex_mode = arr(t["tex_mode"], wp.vec4i, (1, 4))
    m.tex_size = arr(t["tex_size"], wp.vec2i, (1, 2))
    m.tex_u = arr(t["tex_u"], wp.vec3, (1, 3))
    m.tex_v = arr(t["tex_v"], wp.vec3, (1, 3))
    m.texels = arr(t["texels"], wp.vec3, (1, 3))
    m.bump_scale = arr([x.bump_scale for x in materials], float, (1,))
    return t["index"]


def emitter_powers(scene: Scene) -> list[float]:
    """The power of each area light (emitter_shapes order), what the power pick weighs: an emission
    texture counts by its texels' mean (only the pick's odds: any positive weights are unbiased)."""
    def radiance(m) -> float:
        t = m.textures.get("emission")
        mean = 1.0 if t is None else float(np.mean(luminance(t.pixels.reshape(-1, 3))))
        return luminance(m.emission) * mean
    return [max(radiance(scene.materials[s.material]), 1e-12) * s.area() * math.pi
            for s in (scene.shapes[i] for i in scene.emitter_shapes())]


def light_center(s) -> np.ndarray:
    """Where an area light is, for a light selection's distance heuristics: a sphere's centre, a
    quad's middle, a mesh's area-weighted centroid (at shutter open)."""
    if s.kind == "sphere":
        return np.asarray(s.center, dtype=np.float64)
    if s.kind == "quad":
        return np.asarray(s.origin) + 0.5 * (np.asarray(s.edge_u) + np.asarray(s.edge_v))
    v, f = s.mesh.vertices, s.mesh.faces
    w = s.mesh.triangle_areas()
    return (v[f].mean(axis=1) * w[:, None]).sum(axis=0) / max(float(w.sum()), 1e-300)


def _put_lights(sd: SceneData, scene: Scene, spheres: list, quads: list, meshes: list,
                power: list, arr: Callable, tex_index: dict) -> None:
    """Area lights (emitting shapes, picked by power or uniformly), point (and spot) and directional lights."""
    index = {id(s): i for group in (spheres, quads, meshes) for i, s in enumerate(group)}
    code = {"sphere": SPHERE, "quad": QUAD, "mesh": MESH}
    emitters = [scene.shapes[i] for i in scene.emitter_shapes()]
    pmf = np.array(power) / np.sum(power) if power else np.zeros(0)
    cdf = np.cumsum(pmf) if power else np.zeros(0)
    lights = sd.lights
    lights.shape_kind = arr([code[s.kind] for s in emitters], int, (1,))
    lights.shape = arr([index[id(s)] for s in emitters], int, (1,))
    lights.pmf = arr(pmf, float, (1,))
    lights.cdf = arr(cdf, float, (1,))
    lights.center = arr([light_center(s) for s in emitters], wp.vec3, (1, 3))
    lights.n_area = len(emitters)
    points, dirs = scene.point_lights, scene.directional_lights
    lights.point_position = arr([pl.position for pl in points], wp.vec3, (1, 3))
    lights.point_intensity = arr([pl.intensity for pl in points], wp.vec3, (1, 3))
    lights.point_axis = arr([spot_axis(pl) for pl in points], wp.vec3, (1, 3))
    lights.point_cone = arr([spot_cone(pl) for pl in points], wp.vec4, (1, 4))
    rows = [projection_row(pl, tex_index.get(id(pl.texture), -1)) for pl in points]
    lights.point_right = arr([r[0] for r in rows], wp.vec3, (1, 3))
    lights.point_up = arr([r[1] for r in rows], wp.vec3, (1, 3))
    lights.point_proj = arr([r[2] for r in rows], wp.vec4, (1, 4))
    lights.n_point = len(points)
    lights.dir_direction = arr([dl.direction for dl in dirs], wp.vec3, (1, 3))
    lights.dir_irradiance = arr([dl.irradiance for dl in dirs], wp.vec3, (1, 3))
    lights.n_dir = len(dirs)


def camera_basis(cam) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(position, forward, right, up) of a camera, float64 unit vectors: the frame the kernels'
    camera rays are built in."""
    pos = np.asarray(cam.position, dtype=np.float64)
    fwd = np.asarray(cam.look_at, dtype=np.float64) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(cam.up, dtype=np.float64))
    right /= np.linalg.norm(right)
    return pos, fwd, right, np.cross(right, fwd)


# A camera parameter reaches the kernels by its name: every float of CameraData that the Camera model
# also has is copied as it is (the lens's aperture_radius and focus_distance), so a new lens or
# shutter parameter is a field in both and its use in kernels/camera.py, and nothing here.
CAMERA_SCALARS = tuple(name for name, var in CameraData.vars.items()
                       if var.type is wp.float32 and name in {f.name for f in fields(Camera)})


def _put_camera(sd: SceneData, scene: Scene) -> None:
    cam = scene.camera
    pos, fwd, right, up = camera_basis(cam)
    c = sd.camera
    c.position = wp.vec3(*_f3(pos))
    c.right = wp.vec3(*_f3(right))
    c.up = wp.vec3(*_f3(up))
    c.forward = wp.vec3(*_f3(fwd))
    # An orthographic film's half extents are lengths, a perspective one's tangents (kernels/camera.py).
    half_h = cam.ortho_height / 2 if cam.orthographic else math.tan(math.radians(cam.vfov_deg) / 2)
    c.half_height = float(half_h)
    c.half_width = float(half_h * scene.width / scene.height)
    for name in CAMERA_SCALARS:
        setattr(c, name, float(getattr(cam, name)))
    c.shutter_open = float(cam.shutter[0])
    c.shutter_close = float(cam.shutter[1])


def _put_filter(sd: SceneData, camera, arr: Callable) -> None:
    filt = get_filter(camera.filter, camera.filter_stddev)
    sd.filter.cdf = arr(filter_cdf(filt) if filt.name != BOX else np.array([0.0, 1.0]), float, (2,))
    clip = clip_table(filt) if camera.filter_clip and filt.margin else np.zeros((1, 3))
    sd.filter.clip = arr(clip, wp.vec3, (1, 3))


def _put_meshes(sd: SceneData, scene: Scene, meshes: list, arr: Callable, device: str,
                extent: float) -> list:
    """The meshes' BVHs and tables; returns the wp.Bvh objects, which must outlive sd."""
    light_of = {id(scene.shapes[i]): li for li, i in enumerate(scene.emitter_shapes())}
    t_open = float(scene.camera.shutter[0])
    tables = mesh_tables(meshes, t_open, extent)
    built = [_cached(("bvh", device, lo.tobytes(), hi.tobytes()),
                     lambda lo=lo, hi=hi: build_bvh(lo, hi, device))
             for lo, hi in tables.boxes]
    m = sd.meshes
    m.bvh = wp.array(np.array([b.id for b in built] or [0], dtype=np.uint64), dtype=wp.uint64,
                     device=device)
    m.face0 = arr(tables.face0, int, (1,))
    m.tri_index = arr(tables.tri_index, wp.vec3i, (1, 3))
    m.points = arr(tables.points, wp.vec3, (1, 3))
    m.velocity = arr([s.velocity for s in meshes], wp.vec3, (1, 3))
    m.material = arr([s.material for s in meshes], int, (1,))
    m.light = arr([light_of.get(id(s), -1) for s in meshes], int, (1,))
    m.smooth = arr(tables.smooth, int, (1,))
    m.area = arr(tables.area, float, (1,))
    m.centroid = arr(tables.centroid, wp.vec3, (1, 3))
    m.normal_area = arr(tables.normal_area, wp.vec3, (1, 3))
    m.count = len(meshes)
    m.tri_cdf = arr(tables.cdf, float, (1,))
    m.tri_mesh = arr(tables.tri_mesh, int, (1,))
    m.vert_normal = arr(tables.vert_normal, wp.vec3, (1, 3))
    m.vert_uv = arr(tables.vert_uv, wp.vec2, (1, 2))
    return built


def _put_sphere_bvh(sd: SceneData, scene: Scene, spheres: list, device: str,
                    extent: float) -> list:
    """A wp.Bvh over the spheres when they are many (features.uses_sphere_bvh); returns it."""
    sd.spheres.bvh = wp.uint64(0)
    if not uses_sphere_bvh(scene):
        return []
    lowers, uppers = sphere_boxes(spheres, *map(float, scene.camera.shutter), extent)
    bvh = _cached(("bvh", device, lowers.tobytes(), uppers.tobytes()),
                  lambda: build_bvh(lowers, uppers, device))
    sd.spheres.bvh = wp.uint64(bvh.id)
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
    tex_index = _put_materials(sd, scene.materials, arr, scene.point_lights)
    attributes = attribute_tables(texture_pool(scene.materials, scene.point_lights), meshes)
    sd.meshes.attr_first = arr(attributes["attr_first"], wp.vec2i, (1, 2))
    sd.meshes.attr_values = arr(attributes["attr_values"], wp.vec3, (1, 3))
    power = emitter_powers(scene)              # the area lights' pick and the environment's share
    _put_lights(sd, scene, spheres, quads, meshes, power, arr, tex_index)
    sd.environment = environment_data(scene.environment, np.asarray(power),
                                      0.5 * extent, arr)
    _put_camera(sd, scene)
    _put_filter(sd, scene.camera, arr)
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
