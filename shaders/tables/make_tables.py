"""Writes the shaders' precomputed tables (engine/lighting.py _stored): the split-sum
table and the velvet sheen's albedo, as float32 .npy files beside this script. Run
from the repository root after changing how they are computed:

    .venv/bin/python shaders/tables/make_tables.py

tests/test_shading.py checks that the stored tables equal the computation."""
import os

import numpy as np

from lantern.engine.lighting import compute_dfg_lut, compute_velvet_albedo_lut

HERE = os.path.dirname(os.path.abspath(__file__))

if __name__ == "__main__":
    for name, compute in (("dfg_lut", compute_dfg_lut),
                          ("velvet_albedo", compute_velvet_albedo_lut)):
        table = compute().astype(np.float32)
        np.save(os.path.join(HERE, name + ".npy"), table, allow_pickle=False)
        print(f"{name}: {table.shape}, {table.nbytes} bytes")
