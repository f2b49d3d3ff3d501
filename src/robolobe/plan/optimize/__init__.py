"""Spindle speed schedule and depth along a path: global search, casadi refinement, verification.

The decision is one axial depth ``a`` for the whole path (one depth per
pass) and a spindle speed ``n(s)`` along the cutting length ``s``,
piecewise linear between knots (one knot per block of the path). The
objective is the material removal rate over the cycle,
``a * b * L_cut / (T_cut(n) + T_rapid)``, with the feed rate tied to the
speed by the feed per tooth (``v_f = f_z N n / 60``). Constraints at every
cutting waypoint ``i``:

- stability: ``a * SF <= a_lim_i(n_i)`` (``SF`` the safety factor);
- power: ``Kt a b f_z N n_i / 60 <= P_max`` (specific cutting energy ~ Kt);
- torque: ``Kt a b f_z N / (2 pi) <= T_max`` (independent of the speed);
- range: ``rpm_min <= n_i <= min(rpm_max, 60 v_f,max / (f_z N))``;
- rate: ``|dn/ds| <= r_mm`` or ``|dn/dt| <= r_s`` along the cutting length
  (rapids in between are not credited); or one speed for all (``constant``).

Three stages (docs/references.md: planning):

1. **Global search.** A dynamic program over blocks of the path x the speed
   grid, vectorised over a ladder of depths (sliding-window minima by a
   sparse table, so a rate limit costs O(1) per state), finds the fastest
   feasible speed sequence for each depth and the depth with the best MRR.
2. **Refinement.** casadi/IPOPT moves the knot speeds and the depth within
   the stable pockets the search found, with the lobe boundary of every
   constrained waypoint as its cubic B-spline interpolant on the speed grid
   (exact Hessians; ``expand=False`` is not needed because the B-spline
   pieces are written out as SX polynomials; ``nlp_scaling_method=none``,
   started from the search's answer). Waypoints enter the NLP when their
   margin is small (constraint generation: violated ones are added and the
   NLP solved again). Bounded by iterations and rounds (not time: the
   result does not depend on the load), and skipped where it cannot improve
   on its start to first order (:func:`_refine_cannot_improve`; the outcome's
   ``nlp_status`` then says why).
3. **Verification.** Every candidate (refined, searched, best constant
   speed) is checked against the exact lobe boundary at every waypoint
   (:attr:`LobeTable.exact`); its depth becomes the largest one that passes
   every constraint there. Only verified schedules are returned; the best one
   is the plan.

Modules: ``_inputs`` (constraints, lobe table, path geometry), ``_results``
(schedule, outcome), ``_common`` (rate windows, verification, scores),
``_search`` (stage 1), ``_nlp`` (stage 2), ``_api`` (the stages in order).
"""

from robolobe.plan.optimize._api import limit_slacks, limiting_labels, optimize_schedule
from robolobe.plan.optimize._inputs import Constraints, LobeTable, PathGeometry
from robolobe.plan.optimize._results import PlanOutcome, Schedule

__all__ = [
    "Constraints",
    "LobeTable",
    "PathGeometry",
    "PlanOutcome",
    "Schedule",
    "limit_slacks",
    "limiting_labels",
    "optimize_schedule",
]
