"""The local exponent -d ln p(E)/d ln E of the exact model's law on systems/offset-parametric
(issue 45 item 6, docs/systems.md): ``python docs/scripts/local_kappa.py`` (about 5 min on a
loaded 2-core machine: 3000 amplitudes of the exact model's orbit averages)."""

import numpy as np
from vifpk.averaging.stationary import _cumulative
from vifpk.harness.door.solvers import averaged_model

import vifpk
from vifpk.core.energy import parametric_tail

s = vifpk.scene("systems/offset-parametric")
t = parametric_tail(s.system, s.parametric)
print("tail kappa", t.kappa, "crossover", t.crossover)
m = averaged_model(s, "exact")
A = np.geomspace(1e-3, 400, 3001)
with np.errstate(all="ignore"):
    psi, log_pre, _ = _cumulative(m, np.concatenate([[0.0], A]))
lpA = (log_pre + psi)[1:]
k1, k3 = s.system.restoring_law[:2]
E = k1 * A**2 / 2 + k3 * A**4 / 4
lpE = lpA - np.log(k1 * A + k3 * A**3)  # p(E) = p(A) / (dE/dA)
kap = -np.gradient(lpE, np.log(E))
for Et in [1e2, 1e3, 1e4, 1.7e4, 1e5, 1e6, 2e6, 5e6, 1e7, 1e8, 1e9]:
    i = np.searchsorted(E, Et)
    print(f"E={Et:.3g} A={A[i]:.4g} local kappa={kap[i]:.3f} "
          f"ln p(E) - max={lpE[i] - lpE.max():.1f}")
mask = (E > 1e3) & (kap <= 1)
print("first E with local kappa <= 1:", E[mask][0], "A", A[mask][0])
