"""`drtlab info` and `drtlab compare`: what is in an image, and how two images differ (with
per-pixel z-scores where their standard errors are known)."""
from __future__ import annotations

from pathlib import Path

from drtlab import fields
from drtlab.cli_args import Help
from drtlab.errors import InputError


def cmd_info(args) -> int:
    from drtlab.experiments.tools.images import image_info
    print("\n".join(image_info(args.file).lines()))
    return 0


def cmd_compare(args) -> int:
    """A against B, or with --ref each of A and B against R: metrics, error images of each pair,
    and with --per-pixel-z the z-scores (a pair's image and reference standard errors)."""
    from drtlab.experiments.tools import images as tools
    reference = args.ref or args.b
    images = {path: tools.rgb(tools.read_image(path, field)[0], path, field)
              for path, field in ((args.a, "A"), (args.b, "B"), (args.ref, "--ref")) if path}
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
    out_dir = fields.writable_location(args.out_dir, "--out-dir", folder=True)
    pairs = [(args.a, reference)] + ([(args.b, reference)] if args.ref else [])
    stems = [out_dir / f"{Path(path).stem}-vs-{Path(ref_path).stem}" for path, ref_path in pairs]
    fields.output_files([p for stem in stems for p in tools.error_image_paths(stem, args.per_pixel_z)],
                        "--out-dir")
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
    for (path, ref_path), result, stem in zip(pairs, results, stems):
        written += tools.write_error_images(images[path], images[ref_path], stem,
                                            z=None if result.z is None else result.z.image)
    print("wrote " + ", ".join(str(p) for p in written))
    return 0



def add_image_commands(sub) -> None:
    """The `info` and `compare` subcommands on the parser's subparsers `sub`."""
    from drtlab.experiments.paths import results_root
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
    c.add_argument("--ref", default=None, metavar="R", help="measure A and B against this reference")
    c.add_argument("--per-pixel-z", action="store_true",
                   help="per-pixel z-scores (A - B) / standard error, with the reference's standard "
                        "error (and A's, when A.stderr.exr exists)")
    c.add_argument("--stderr", default=None, metavar="FILE",
                   help="standard-error image of the reference (default: found beside it)")
    c.add_argument("--out-dir", type=Path, default=results_root() / "compare",
                   help="where the error images go")
    c.set_defaults(func=cmd_compare)
