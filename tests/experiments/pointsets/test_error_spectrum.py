"""experiments/pointsets/error_spectrum.py: exact properties of the error-image spectrum on synthetic images
(white noise is flat at its variance, a one-cycle smooth error is all low frequency, a checkerboard
is all at the corner frequency (Nyquist, Nyquist)), the whole path through a fake experiment folder
(run images + reference written as the runner and study/ground_truth write them, no rendering), and the
one-line errors of the command (exit 2, nothing written)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import drtlab.experiments.pointsets.error_spectrum as ES
from drtlab.errors import InputError
from drtlab.experiments.study.run_store import CellFile, commit


# ---------------------------------------------------------------------------------------------------
# Synthetic images
# ---------------------------------------------------------------------------------------------------

def test_white_noise_is_flat_at_its_variance():
    rng = np.random.default_rng(1)
    sigma = 0.3
    imgs = [rng.normal(0.0, sigma, size=(36, 48)) for _ in range(200)]
    st = ES.spectrum_stats(imgs)
    m, se = np.asarray(st["radial_mean"]), np.asarray(st["radial_se"])
    z = (m - sigma ** 2) / se
    assert np.all(np.abs(z) < 4.5), z          # every ring within 4.5 standard errors of s^2
    assert np.mean(np.abs(z) < 2.0) > 0.8
    p = st["power"]
    assert p["lo"] < sigma ** 2 < p["hi"]
    lf = st["low_fraction"]
    assert lf["lo"] < st["white_fraction"] < lf["hi"]
    assert st["low_fraction_relative_to_white"] == pytest.approx(1.0, abs=0.15)
    # the white fraction is the share of non-DC frequencies under the cutoff (0.125 cycles/px)
    fy, fx = np.meshgrid(np.fft.fftfreq(36), np.fft.fftfreq(48), indexing="ij")
    r = np.hypot(fx, fy)
    assert st["white_fraction"] == ((r > 0) & (r < 0.125)).sum() / (r.size - 1)


def test_smooth_error_is_all_low_frequency():
    h, w = 36, 48
    y, x = np.mgrid[0:h, 0:w]
    err = 0.7 * np.sin(2 * np.pi * x / w) + 0.2 * np.cos(2 * np.pi * y / h) + 5.0    # offset removed
    s = ES.image_spectrum(err)
    assert s["low_fraction"] == pytest.approx(1.0, abs=1e-12)
    # power sits in the first ring only (|f| = 1/48 and 1/36 both round to ring 1 of df = 1/36)
    assert s["radial"][0] > 0
    assert np.all(s["radial"][1:] < 1e-20 * s["radial"][0])
    # Parseval: mean power per frequency = pixel variance (over W H - 1 non-DC frequencies)
    assert s["power"] * (h * w - 1) == pytest.approx(err.var() * h * w, rel=1e-12)
    # a smooth blob is nearly all low frequency too
    blob = np.exp(-((x - 24) ** 2 + (y - 18) ** 2) / (2 * 6.0 ** 2))
    assert ES.image_spectrum(blob)["low_fraction"] > 0.99


def test_checkerboard_is_power_at_nyquist_only():
    h, w = 36, 48
    y, x = np.mgrid[0:h, 0:w]
    err = np.where((x + y) % 2 == 0, 1.0, -1.0)
    p = ES.periodogram2d(err)
    assert p[h // 2, w // 2] == pytest.approx(h * w)
    p[h // 2, w // 2] = 0.0
    assert np.all(p < 1e-18)
    s = ES.image_spectrum(err)
    assert s["low_fraction"] == pytest.approx(0.0, abs=1e-15)
    assert s["low_fraction_x"] == pytest.approx(0.0, abs=1e-15)
    k = int(np.argmax(s["radial"]))
    assert s["radii"][k] == pytest.approx(round(math.sqrt(0.5) * 36) / 36)    # the corner's ring
    assert k == len(s["radii"]) - 1                                         # the outermost ring
    assert np.all(np.delete(s["radial"], k) < 1e-18)
    # stripes along x: Nyquist in f_x, all power at |f_x| = 0.5, none below the x cutoff
    stripes = np.where(x % 2 == 0, 1.0, -1.0)
    sx = ES.image_spectrum(stripes)
    assert sx["low_fraction_x"] == pytest.approx(0.0, abs=1e-15)
    assert sx["low_fraction_y"] == pytest.approx(1.0, abs=1e-12)


def test_welch_difference_covers_zero_for_equal_means():
    rng = np.random.default_rng(3)
    d = ES.welch_difference(rng.normal(0, 1, 50), rng.normal(0, 1, 50))
    assert d["lo"] < 0 < d["hi"]
    d = ES.welch_difference(rng.normal(5, 1, 20), rng.normal(0, 1, 20))
    assert d["lo"] > 3


# ---------------------------------------------------------------------------------------------------
# A fake experiment folder
# ---------------------------------------------------------------------------------------------------

W, H, REPS = 16, 12, 3


def _fake_experiment(tmp_path):
    rng = np.random.default_rng(7)
    out, gt_root = tmp_path / "exp", tmp_path / "gt"
    ref = np.full((H, W, 3), 0.5)
    gdir = gt_root / f"sc__drt__{W}x{H}"
    gdir.mkdir(parents=True)
    out.mkdir(parents=True)
    np.savez(gdir / "gt.npz", mean=ref, m2=np.zeros_like(ref), batches=4, batch_spp=16)
    (gdir / "manifest.json").write_text(json.dumps({"key": "k1"}))
    y, x = np.mgrid[0:H, 0:W]
    records = {}
    for sampler in ("white", "smooth"):
        for spp in (1, 4):
            cell = f"sc__{sampler}__drt__{W}x{H}__spp{spp:05d}"
            images = []
            for rep in range(REPS):
                if sampler == "white":
                    e = rng.normal(0, 0.1, (H, W))
                else:
                    e = 0.1 * np.sin(2 * np.pi * x / W + rep)
                images.append(ref + e[..., None])
                rid = f"{cell}__rep{rep:02d}"
                records[rid] = {"run_id": rid, "cell": cell, "batch": "b0", "scene": "sc",
                                "scene_key": "sc", "sampler": sampler, "integrator": "drt",
                                "width": W, "height": H, "spp": spp, "rep": rep, "gt_key": "k1"}
            # Repetitions committed out of order (as a cluster's batches may be): read back in order.
            order = [2, 0, 1]
            cf = CellFile(None).with_batch("b0", np.stack([images[i] for i in order]), order, True)
            commit(out, records, list(records), {cell: cf})
    return out, gt_root


def test_experiment_folder_end_to_end(tmp_path):
    out, gt_root = _fake_experiment(tmp_path)
    rc = ES.main([str(out), "--scene", "sc", "--spp", "4", "--samplers", "smooth,white",
                  "--gt-dir", str(gt_root)])
    assert rc == 0
    res = json.loads((out / "spectrum" / "error_spectrum.json").read_text())
    assert (out / "spectrum" / "error_spectrum.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert res["reference_matches_runs"] is True
    sm, wh = res["samplers"]["smooth"], res["samplers"]["white"]
    assert sm["repetitions"] == wh["repetitions"] == REPS
    assert sm["low_fraction"]["mean"] == pytest.approx(1.0, abs=1e-9)
    assert wh["low_fraction"]["mean"] < 0.5
    c = res["comparisons"][0]
    assert (c["sampler"], c["versus"]) == ("smooth", "white")
    assert c["low_fraction_difference"]["lo"] > 0.3


@pytest.mark.parametrize("args, flag", [
    (["--scene", "nope", "--spp", "4"], "--scene"),
    (["--scene", "sc", "--spp", "4", "--samplers", "white,bogus"], "--samplers"),
    (["--scene", "sc", "--spp", "4", "--samplers", "white,white"], "--samplers"),
    (["--scene", "sc", "--spp", "16", "--samplers", "white"], "--spp"),
    (["--scene", "sc", "--spp", "-3", "--samplers", "white"], "--spp"),
    (["--scene", "sc", "--spp", "4", "--samplers", "white", "--cutoff", "0"], "--cutoff"),
])
def test_bad_input_is_one_line(tmp_path, capsys, args, flag):
    out, gt_root = _fake_experiment(tmp_path)
    rc = ES.main([str(out), *args, "--gt-dir", str(gt_root)])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert len(err.splitlines()) == 1 and err.startswith(f"drtlab: {flag}:"), err
    assert not (out / "spectrum").exists()


def test_missing_results_dir_is_one_line(tmp_path, capsys):
    rc = ES.main([str(tmp_path / "absent"), "--scene", "sc", "--spp", "4"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and err.startswith("drtlab: RESULTS_DIR:"), err
    assert not (tmp_path / "absent").exists()


def test_missing_reference_is_one_line(tmp_path, capsys):
    out, _ = _fake_experiment(tmp_path)
    rc = ES.main([str(out), "--scene", "sc", "--spp", "4", "--samplers", "white",
                  "--gt-dir", str(tmp_path / "nogt")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and err.startswith("drtlab: --gt-dir:"), err
