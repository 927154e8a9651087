"""Command-line tools on images and BSDF lobes (`drtlab info`, `compare`, `lobe`). May import stats/
(chi2) and study/ (metrics, manifest)."""
