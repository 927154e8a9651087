"""Ray-shape intersection: primitive tests and ray offsets, quad records and box groups, BVH build and
traversal (meshes, many spheres), and the per-variant scene queries (nearest hit, visibility)."""
