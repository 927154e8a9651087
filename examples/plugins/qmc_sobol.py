"""A tabulated point set: the first 1024 points of scipy's unscrambled Sobol' sequence in 5
dimensions (pixel, lens and time read jointly), Owen-scrambled per pixel by drtlab
(`drtlab.pointset_from_table`). Owen scrambling keeps the table's (t,m,s)-net structure, so at
spp = 2^m every pixel's points in dimensions (0, 1) form a (0,m,2)-net; dimensions past the table's
5 are padded with permuted copies of its first two. (With 8 joint dimensions `drtlab validate`
fails it: Sobol' dimensions 1 and 7 of 64 points are correlated, and pixel.y and light_pos0.y would
read them together.)"""
from scipy.stats import qmc

import drtlab

drtlab.register_pointset(drtlab.pointset_from_table(
    "qmc-sobol", qmc.Sobol(5, scramble=False), n=1024, randomize="owen",
    description="scipy.stats.qmc Sobol' (1024 points, 5 dimensions)"))
