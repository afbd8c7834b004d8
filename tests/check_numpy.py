"""Checks that a FieldProbe dataset loads with NumPy exactly as Kato's published files do.

usage: python3 tests/check_numpy.py DATA_DIR SYNSET [SYNSET ...]
"""
import sys

import numpy as np

data, synsets = sys.argv[1], sys.argv[2:]
for synset in synsets:
    for split in ("train", "val", "test"):
        images = np.load(f"{data}/{synset}_{split}_images.npz")["arr_0"]
        voxels = np.load(f"{data}/{synset}_{split}_voxels.npz")["arr_0"]
        n = images.shape[0]
        assert images.dtype == np.uint8 and images.shape == (n, 24, 4, 64, 64), images.shape
        assert voxels.dtype == np.bool_ and voxels.shape == (n, 32, 32, 32), voxels.shape
        alpha = images[:, :, 3]
        assert alpha.max() == 255 and alpha[:, :, 0, 0].max() == 0, "silhouettes, empty corners"
        assert voxels.reshape(n, -1).sum(1).min() > 0, "every object has voxels"
        print(f"numpy: {synset}_{split}: images {images.shape} {images.dtype}, "
              f"voxels {voxels.shape} {voxels.dtype}, mean occupancy {voxels.mean():.3f}")
print("numpy check: ok")
