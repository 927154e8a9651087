"""The device copy of the scene: the SceneData struct the kernels read (kernels/scene_upload.py
fills it with `upload`), its nested parts and the shape-kind codes."""
import warp as wp

from drtlab.kernels.intersection.primitives import QuadGeom

# Shape kinds (Hit.kind, LightData.shape_kind).
SPHERE = wp.constant(0)
QUAD = wp.constant(1)
MESH = wp.constant(2)           # Hit.index: the face's index in the per-face arrays (tri_*)


# The environment light's tables (kernels/environment.py fills them with `environment_data`).
@wp.struct
class EnvironmentData:
    radiance: wp.array(dtype=wp.vec3)          # H x W texels, row-major, row 0 = +y
    texel_pdf: wp.array(dtype=float)           # per texel: the image sampler's density over (u, v)
    marginal: wp.array(dtype=float)            # H + 1: cdf over rows
    conditional: wp.array(dtype=float)         # H x (W + 1): cdf over columns, per row
    width: int
    height: int
    pick_power: float                          # P(environment) when lights are picked by power
    pick_uniform: float                        # ... and when picked uniformly: 1 / (area lights + 1)
    rotated: int                               # 1: to_world turns the map (else both identity)
    to_world: wp.mat33                         # the map's frame -> world
    to_local: wp.mat33                         # its transpose
    bilinear: int                              # 1: lookup = "bilinear" (environment_map.py)


@wp.struct
class SphereData:
    center: wp.array(dtype=wp.vec3)            # at shutter open
    radius: wp.array(dtype=float)
    velocity: wp.array(dtype=wp.vec3)
    material: wp.array(dtype=int)
    light: wp.array(dtype=int)                 # its area light, -1 none
    to_local: wp.array(dtype=wp.mat33)         # world -> its own frame (Shape.to_local): a texture's uv
    count: int
    bvh: wp.uint64                             # wp.Bvh over the spheres' swept boxes; 0: none


@wp.struct
class QuadData:
    origin: wp.array(dtype=wp.vec3)            # at shutter open
    u: wp.array(dtype=wp.vec3)
    v: wp.array(dtype=wp.vec3)
    normal: wp.array(dtype=wp.vec3)
    geom: wp.array(dtype=QuadGeom)             # what the ray tests read (quad_records.quad_geometry)
    area: wp.array(dtype=float)
    velocity: wp.array(dtype=wp.vec3)
    material: wp.array(dtype=int)
    light: wp.array(dtype=int)
    group: wp.array(dtype=int)                 # its group in QuadGroupData
    count: int
    # The CPU's vector test (Features.quad_simd): blocks of quad_simd.LANES quads
    # (quad_simd.quad_pack of quad_records.vector_lanes), and per quad 1 if it is a lane there.
    pack: wp.array(dtype=float)
    blocks: int
    lane: wp.array(dtype=int)


@wp.struct
class QuadGroupData:
    """The quads as groups in index order (quad_records.quad_groups): single quads and boxes."""
    quad: wp.array(dtype=int)                  # a single quad's index, -1 for a box
    corner: wp.array(dtype=wp.vec3)
    inverse: wp.array(dtype=wp.mat33)
    aligned: wp.array(dtype=int)               # box: 1 if axis-aligned (inverse diagonal)
    ball: wp.array(dtype=wp.vec4)              # closed box: a ball around it; radius < 0: none
    velocity: wp.array(dtype=wp.vec3)
    rank: wp.array(dtype=int)
    faces: wp.array(dtype=int)                 # 6 per group: quad index by face slot, -1 none
    count: int
    box: wp.array(dtype=int)                   # the groups the vector test leaves to slab tests
    n_box: int


@wp.struct
class MeshData:
    """Triangle meshes (kernels/intersection/bvh_build.py), vertices at shutter open: per mesh a
    wp.Bvh of its triangles' boxes (item k: the mesh's face k), per face and per vertex tables."""
    bvh: wp.array(dtype=wp.uint64)
    face0: wp.array(dtype=int)                 # count + 1 offsets into the per-face arrays
    velocity: wp.array(dtype=wp.vec3)
    material: wp.array(dtype=int)
    light: wp.array(dtype=int)
    smooth: wp.array(dtype=int)                # 1: shading normals interpolated from vert_normal
    area: wp.array(dtype=float)
    centroid: wp.array(dtype=wp.vec3)          # Whitted's point-light stand-in
    normal_area: wp.array(dtype=wp.vec3)       # sum over faces of area * unit normal
    count: int
    tri_index: wp.array(dtype=wp.vec3i)        # per face: its vertices in points
    tri_cdf: wp.array(dtype=float)             # per face: area cdf within its mesh
    tri_mesh: wp.array(dtype=int)              # per face: its mesh
    points: wp.array(dtype=wp.vec3)            # every mesh's vertices
    vert_normal: wp.array(dtype=wp.vec3)       # per vertex (zeros in flat meshes)
    vert_uv: wp.array(dtype=wp.vec2)           # per vertex texture coordinates (read by textures)
    # Mesh attributes (kernels/materials/mesh_attribute.py), read only by a variant with them: per
    # (pool texture, mesh) the offset of its values and 1 if per vertex; the values
    attr_first: wp.array(dtype=wp.vec2i)
    attr_values: wp.array(dtype=wp.vec3)


@wp.struct
class MaterialData:
    kind: wp.array(dtype=int)                  # material_kinds.MATERIAL_CODE
    albedo: wp.array(dtype=wp.vec3)
    albedo2: wp.array(dtype=wp.vec3)
    checker: wp.array(dtype=wp.vec2)
    shape: wp.array(dtype=float)               # the lobe's shape (MaterialKind.shape)
    shape_v: wp.array(dtype=float)             # an anisotropic kind's alpha_v (MaterialKind.shape_v);
                                               # read only by a variant with one
    ior: wp.array(dtype=float)
    emission: wp.array(dtype=wp.vec3)
    eta: wp.array(dtype=wp.vec3)               # a conductor's complex index eta + i k, per channel
    k: wp.array(dtype=wp.vec3)
    # Rows of per-material data a kind's model reads (MaterialKind.table), one flat array, and each
    # material's row offset (0 for the others).
    table: wp.array(dtype=float)
    row: wp.array(dtype=int)
    # A mask's opacity and 1 for a one-sided material (kernels/materials/mask.py), read only by a
    # variant with masks or one-sided materials.
    opacity: wp.array(dtype=float)
    one_sided: wp.array(dtype=int)
    # Textures (kernels/materials/texture.py), read only by a variant with textures: each material's
    # pool index per slot (material-major, -1: none; material_texture reads it) and whether it has
    # any; per pool texture its (kind, filter, wrap, first texel), its width and height, its to_uv
    # rows; every texture's texels, row by row from the image's top.
    tex: wp.array(dtype=int)
    textured: wp.array(dtype=int)
    tex_mode: wp.array(dtype=wp.vec4i)
    tex_size: wp.array(dtype=wp.vec2i)
    tex_u: wp.array(dtype=wp.vec3)
    tex_v: wp.array(dtype=wp.vec3)
    texels: wp.array(dtype=wp.vec3)
    bump_scale: wp.array(dtype=float)          # per material: its bump map's scale (shading_frame.py)
    shape_v: wp.array(dtype=float)             # per material: an anisotropic kind's alpha_v (else 0)


@wp.struct
class LightData:
    # Area lights (emitting shapes), li < n_area.
    shape_kind: wp.array(dtype=int)            # SPHERE, QUAD or MESH
    shape: wp.array(dtype=int)                 # its index among the shapes of its kind
    pmf: wp.array(dtype=float)                 # by power
    cdf: wp.array(dtype=float)
    center: wp.array(dtype=wp.vec3)            # where it is, for light selection (light_center)
    n_area: int
    point_position: wp.array(dtype=wp.vec3)
    point_intensity: wp.array(dtype=wp.vec3)
    point_axis: wp.array(dtype=wp.vec3)        # a spot's unit axis, and its cone (kernels/spot.py:
    point_cone: wp.array(dtype=wp.vec4)        # spot_cone); read only by a variant with spots
    point_right: wp.array(dtype=wp.vec3)       # a projection's frame x, y and its factors and texture
    point_up: wp.array(dtype=wp.vec3)          # (kernels/projection.py: projection_row); read only by
    point_proj: wp.array(dtype=wp.vec4)        # a variant with projections
    n_point: int
    dir_direction: wp.array(dtype=wp.vec3)     # the way the light travels
    dir_irradiance: wp.array(dtype=wp.vec3)
    n_dir: int


@wp.struct
class CameraData:
    position: wp.vec3
    right: wp.vec3
    up: wp.vec3
    forward: wp.vec3
    half_width: float
    half_height: float
    aperture_radius: float     # 0: a pinhole (kernels/camera.py tests it per sample)
    focus_distance: float
    shutter_open: float
    shutter_close: float


@wp.struct
class FilterData:
    """A non-box pixel filter's sampling table (kernels/filters.py: filter_cdf; its size, the radius
    and the integral are compile-time constants of the filter's variant); unused by the box."""
    cdf: wp.array(dtype=float)      # bins + 1 values, 0 ... 1
    # Truncated to the film (filters.clip_table): per pixel 0 .. margin - 1 from the edge, the CDF at
    # the cut on the left and on the right, and the integral beyond the cut; one unused row otherwise.
    clip: wp.array(dtype=wp.vec3)


@wp.struct
class SceneData:
    """The scene as the kernels read it, in parts: its shapes by kind, materials, lights, camera,
    then the render settings. Nesting costs nothing: sd.camera.position is one load at a fixed
    offset, as a flat field was (the compiled kernels have the same instructions)."""
    spheres: SphereData
    quads: QuadData
    quad_groups: QuadGroupData
    meshes: MeshData
    materials: MaterialData
    lights: LightData
    environment: EnvironmentData               # the [environment] light (kernels/environment.py)
    camera: CameraData
    filter: FilterData
    background: wp.vec3
    eps: float                                 # ray-origin offset at the scene's scale
    width: int
    height: int
    max_depth: int
    rr_depth: int
    whitted_codes: int
    moving: int                 # 1: shapes move within the shutter (intersection/motion.py)
