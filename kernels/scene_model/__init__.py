"""The scene model: scene files (TOML, Mitsuba 3 XML) read, validated and held in numpy, with no
Warp code (kernels/scene_upload.py makes the device copy)."""
