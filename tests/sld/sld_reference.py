"""Reference system of the sld tests (REFERENCES.md section 3).

It is the system of Insperger, Mann, Stepan & Bayly 2003, "Stability of
up-milling and down-milling, part 1", Int. J. Mach. Tools Manuf. 43:25-34:
N = 2 teeth, Kt = 6e8 N/m^2, Kn = 2e8 N/m^2, f_n = 922 Hz, zeta = 0.011,
m = 0.03993 kg. The reference depths are reproduced with
``k = m (2 pi f_n)^2`` (1.34005e6 N/m); REFERENCES.md rounds it to
1.340e6 N/m, which lowers every depth by 3.7e-5 relative.
"""

from __future__ import annotations

import math

N_TEETH = 2
KT = 6e8
KN = 2e8
KR = KN / KT
F_N = 922.0
ZETA = 0.011
MASS = 0.03993
K_MODAL = MASS * (2 * math.pi * F_N) ** 2
