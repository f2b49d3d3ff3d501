"""Stock and the in-process workpiece: engagement of the cutter on every move.

Knows nothing of robots, dynamics or lobes: it takes tool-tip positions, the
cutter and the stock, and returns per move the radial engagement (entry and
exit angles in the feed frame of :mod:`robolobe.sld.directional`), the axial
depth of cut and whether the tool cuts at all.

- :class:`Stock`, :func:`default_stock`, :func:`check_stock_contains`: stock definitions.
- :func:`compute_engagement`, :class:`Engagement`: the Z-map material removal
  (flat end mills) and the engagement per move.
"""

from __future__ import annotations

from robolobe.stock.engagement import (
    LEVEL_TOL_M,
    MIN_ARC_DEG,
    Engagement,
    compute_engagement,
    zmap_resolution,
)
from robolobe.stock.shapes import Stock, check_stock_contains, default_stock, signed_distance

__all__ = [
    "LEVEL_TOL_M",
    "MIN_ARC_DEG",
    "Engagement",
    "Stock",
    "check_stock_contains",
    "compute_engagement",
    "default_stock",
    "signed_distance",
    "zmap_resolution",
]
