"""`drtlab info` and `drtlab compare`: what is in an image, and how two images differ (with
per-pixel z-scores where their standard errors are known)."""
from __future__ import annotations

from pathlib import Path

from drtlab import fields
from drtlab.cli_args import Help, path_flag
from drtlab.errors import InputError


def cmd_info(args) -> int:
    from drtlab.experiments.tools.images import image_info
    print("\n".join(image_info(args.file).lines()))
    return 0


def cmd_compare(args) -> int:
    """A against B, or with --ref each of A and B against R: metrics, error images of each pair,
    and with --per-pixel-z the z-scores (a pair's image and reference standard errors)."""
    from drtlab.experiments.tools import images as tools
    import numpy as np
    from drtlab.kernels.imageio import nonfinite_note
    reference = args.ref or args.b
    if args.stderr is not None and not args.per_pixel_z:
        raise InputError("--stderr", "is read by --per-pixel-z only (the metrics need no standard "
                                     "error): add --per-pixel-z or drop --stderr")
    pairs = [(args.a, reference)] + ([(args.b, reference)] if args.ref else [])
    stems = tools.pair_stems(pairs, ("A", "B"))        # distinct output names, checked first
    images = {path: tools.rgb(tools.read_image(path, field)[0], path, field)
              for path, field in ((args.a, "A"), (args.b, "B"), (args.ref, "--ref")) if path}
    for path, field in ((args.a, "A"), (args.b, "B"), (args.ref, "--ref")):
        bad = nonfinite_note(images[path]) if path else None
        if bad:
            raise InputError(field, f"{path}: {bad} (`drtlab info {path}` counts them): error "
                                    "metrics of it are undefined")
    se = {}                                     # path -> (standard error, values behind it)
    if args.per_pixel_z:
        se_path = args.stderr or tools.stderr_beside(reference)
        if se_path is None:
            raise InputError("--per-pixel-z", f"needs the standard error of {reference}: "
                             "--stderr FILE, or X.stderr.exr beside X.exr (stderr.exr beside a "
                             "ground truth's mean.exr)")
        def read_se(se_file, of, field):
            pixels, meta = tools.read_image(se_file, field)
            pixels = tools.rgb(pixels, se_file, field)
            want = images[of].shape[:2]
            if pixels.shape[:2] != want:
                raise InputError(field, f"the standard error {se_file} is {pixels.shape[1]}x{pixels.shape[0]} "
                                        f"but {of} is {want[1]}x{want[0]}: they must have the same resolution")
            bad = int(np.count_nonzero(~(pixels >= 0.0)))       # negative, NaN
            if bad or not np.isfinite(pixels).all():
                raise InputError(field, f"the standard error {se_file} has {bad or 'Inf'} values that "
                                        "are not finite numbers >= 0: a standard error is one")
            se[of] = (pixels, tools.samples_behind(meta))

        read_se(se_path, reference, "--stderr")
        for path, field in ((args.a, "A"), (args.b, "B") if args.ref else (None, None)):
            beside = tools.stderr_beside(path) if path else None
            if beside is not None:
                read_se(beside, path, field)
            elif path and tools.read_image(path, field)[1].get("sampler") != "none":
                # Taking a noisy image's standard error as 0 counts its noise as a difference (the
                # example above gave |z| > 3 in 26% of pixels instead of 1.6%).
                raise InputError("--per-pixel-z", f"{path} has no standard error beside it "
                                 f"({Path(path).stem}.stderr.exr, which `drtlab render --variance` "
                                 "writes): its noise would count as a difference; render it with "
                                 "--variance (only a deterministic whitted image needs none)")
    from drtlab.experiments.paths import results_root
    out_dir = args.out_dir if args.out_dir is not None else results_root() / "compare"
    out_dir = fields.writable_location(out_dir, "--out-dir", folder=True)
    fields.output_files([p for stem in stems
                         for p in tools.error_image_paths(out_dir / stem, args.per_pixel_z)], "--out-dir")
    results = []
    for path, ref_path in pairs:
        se_img, n_img = se.get(path, (None, None))
        se_ref, n_ref = se.get(ref_path, (None, None))
        result = tools.compare_images(images[path], images[ref_path], names=(path, ref_path),
                                      se_a=se_img, se_b=se_ref, n_a=n_img, n_b=n_ref)
        print(result.line())
        results.append(result)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for (path, ref_path), stem, result in zip(pairs, stems, results):
        written += tools.write_error_images(images[path], images[ref_path], out_dir / stem,
                                            z=None if result.z is None else result.z.image)
    print("wrote " + ", ".join(str(p) for p in written))
    return 0



def add_image_commands(sub) -> None:
    """The `info` and `compare` subcommands on the parser's subparsers `sub`."""
    i = sub.add_parser("info", help="resolution, channel statistics, NaN/Inf/negative counts and "
                                    "drtlab metadata of an EXR", formatter_class=Help)
    i.add_argument("file", metavar="FILE", help="an EXR (or any image OpenImageIO reads)")
    i.set_defaults(func=cmd_info)
    c = sub.add_parser("compare", help="error metrics of A against B, and error images",
                       formatter_class=Help,
                       description="RMSE, relMSE, MAE, CIEDE2000 and mean signed error of A against "
                                   "B (or of A and B against --ref); writes a signed-difference EXR "
                                   "and a false-colour error PNG of A - B.")
    c.add_argument("a", metavar="A", help="image to measure")
    c.add_argument("b", metavar="B", help="reference image (or a second image, with --ref)")
    c.add_argument("--ref", type=path_flag, default=None, metavar="R",
                   help="measure A and B against this reference")
    c.add_argument("--per-pixel-z", action="store_true",
                   help="per-pixel z-scores (A - B) / standard error, with the reference's standard "
                        "error (and A's, when A.stderr.exr exists)")
    c.add_argument("--stderr", type=path_flag, default=None, metavar="FILE",
                   help="standard-error image of the reference (default: found beside it)")
    c.add_argument("--out-dir", type=path_flag, default=None,
                   help="where the error images go (default: results/compare)")
    c.set_defaults(func=cmd_compare)
