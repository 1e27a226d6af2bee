"""Fits the linearly transformed cosines of the GGX lobe (engine/ltc.py) and stores
them as shaders/tables/ltc_ggx.npy, float32 (LTC_SIZE x LTC_SIZE x 4), which
engine/lighting.py ltc_lut loads for shaders/ltc.glsl. Rows are fitted in parallel
(about 20 minutes on 2 cores). Run from the repository root after changing the lobe:

    .venv/bin/python shaders/tables/fit_ltc.py [processes]

tests/test_ltc.py fits a few texels again and checks the stored table against them."""
import os
import sys
from multiprocessing import Pool

import numpy as np

from lantern.engine.ltc import LTC_SIZE, fit_row

HERE = os.path.dirname(os.path.abspath(__file__))

if __name__ == "__main__":
    processes = int(sys.argv[1]) if len(sys.argv) > 1 else os.cpu_count()
    with Pool(processes) as pool:
        rows = pool.map(fit_row, range(LTC_SIZE), chunksize=1)
    table = np.stack(rows).astype(np.float32)
    if not np.isfinite(table).all():
        raise SystemExit("ltc_ggx: the fit gave non-finite entries; nothing written")
    np.save(os.path.join(HERE, "ltc_ggx.npy"), table, allow_pickle=False)
    print(f"ltc_ggx: {table.shape}, {table.nbytes} bytes")
