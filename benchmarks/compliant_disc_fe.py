import time

import numpy as np

from cyclomesh import TABLE1, Modification
from cyclomesh.fe.disc import solve_disc_fe

out = {}
for name, mod in (("TPM", Modification(pin_radius=8e-6)), ("noTPM", Modification())):
    for deg in (0.0, 3.0, 6.0):
        t = time.perf_counter()
        r = solve_disc_fe(TABLE1, mod, 250.0, np.deg2rad(deg), 30e-3, 10.0, 2e-3, "half_plane")
        out[f"{name}_{deg:g}_load"] = r.pin_load_fe
        out[f"{name}_{deg:g}_rot"] = r.rotation_fe
        out[f"{name}_{deg:g}_rest"] = r.rest_rotation
        print(name, deg, r.rotation_fe, time.perf_counter() - t, flush=True)
        np.savez("/tmp/fe_ref.npz", **out)
