"""The building blocks every tracker kernel is made of, in one namespace (``blocks.predict``, ...).

* :mod:`.kalman`: predict (one trial and lanes) and scalar measurement
  updates on lanes (Vila-Valls et al. 2018, eqs. 8, 11; Susi et al. 2014, eq. 12);
* :mod:`.aekf`: the AEKF-AR's structured AR prediction and I/Q EKF update
  (eqs. 8, 11, 13-14), mirror fold, nearest adaptation point;
* :mod:`.discriminators`: ATAN2 and Costas discriminators and their variances;
* :mod:`.covariance`: symmetrisation and the divergence guard's test of P;
* :mod:`.loop_filter`: the third-order PLL loop filter;
* :mod:`.windows`: the M2M4 window on lanes;
* the estimators' formulas (M2M4, C/N0, window moments, noise-corrected S4):
  :mod:`scintrack.estimators.formulas`; the ``Lanes`` type: :mod:`scintrack.simd`.

Every block is an ``@njit`` function written so that the compiled arithmetic
is the textbook expression's, operand by operand (never turn fastmath on).
"""

from ...estimators.formulas import *  # noqa: F403
from ...simd import LANES as LANES
from ...simd.lanes import lane_trials as lane_trials
from ...simd.lanes import lanes_any_zero as lanes_any_zero
from ...simd.lanes import lanes_empty as lanes_empty
from ...simd.lanes import select_less as select_less
from .aekf import *  # noqa: F403
from .covariance import *  # noqa: F403
from .discriminators import *  # noqa: F403
from .kalman import *  # noqa: F403
from .loop_filter import *  # noqa: F403
from .windows import *  # noqa: F403
