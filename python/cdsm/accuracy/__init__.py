"""Accuracy studies of the nominal model: how errors in the cable lengths and
hole positions move the tip (SI units: m, rad).

=====================  ==========================================================
module                 holds
=====================  ==========================================================
``scenarios``          one error scenario at a time (the paper's Fig. 3)
``workspace``          joint grids, the two study protocols, singular states, jump points
``montecarlo``         random composite errors (Fig. 7), statistics, ``.npz`` files
``distributed``        the same Monte Carlo on a Dask cluster, bit for bit
``sensitivity``        first-order sensitivities, amplification maps, linear vs nonlinear
``tolerance``          tolerance allocation and tip-error distributions per region
``configurations``     least-sensitive configurations and paths
``statics``            slack-cable maps and elastic-cable tip deviations
=====================  ==========================================================
"""

from .montecarlo import MonteCarlo, monte_carlo
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL, Deviation, deviation
from .sensitivity import Sensitivities, amplification, sensitivities
from .tolerance import Allocation, allocate, distribution
from .workspace import Workspace, jump_points, joint_grid, paper_ik_seed, singular_values, sweep

__all__ = ["deviation", "Deviation", "monte_carlo", "MonteCarlo", "joint_grid", "paper_ik_seed",
           "sweep", "Workspace", "jump_points", "singular_values", "sensitivities", "Sensitivities",
           "amplification", "allocate", "Allocation", "distribution", "PAPER_DL_TOL", "PAPER_DH_TOL"]
