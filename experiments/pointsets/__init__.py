"""Point-set analysis (`drtlab pointset`, `drtlab validate`): discrepancy, spectra, plots, the statistical
validation battery and the error spectrum of a study's runs. May import stats/ and study/ (run files)."""
