"""Random 2.5-D moves against an exact reference written for the test (no grid).

Each case cuts a random history into a box of stock (a slot along a line, an
arc read as chords within 10 um, a corner of two lines, a ramp between two
levels), then probes one short move (longer than the production's lag of two
cells, shorter than its sample step: one sample, at its end, with the whole
history removed) at a random place and direction: across the history, along
a slot's wall at the slot's own offset (a tangent graze), on a ramp's floor.

The reference decides material at a point of the cutting edge exactly: inside
the box by more than the level tolerance, and not cleared to within the level
tolerance of the tip by any history move (a point is cleared by a move to the
lowest tip height over the part of the move within the tool radius, grown by
the tolerance: material thinner than it in x-y or z is none). The edge is
sampled every 0.1 deg and each change refined by bisection.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.stock import LEVEL_TOL_M, Stock, compute_engagement

from ._arc import engaged_arc

R = 0.005  # tool radius [m]
D = 2 * R
BOX = ((-0.03, -0.03, -0.012), (0.03, 0.03, 0.0))
LEVELS = (-0.002, -0.004, -0.006)


class Exact:
    """Exact material test against a list of straight moves (m)."""

    def __init__(self, moves: list[tuple[np.ndarray, np.ndarray]], tol: float) -> None:
        self.a = np.array([m[0] for m in moves])
        self.b = np.array([m[1] for m in moves])
        self.tol = tol

    def top(self, q: np.ndarray) -> np.ndarray:
        """Material top at points q (k, 2) [m]."""
        rr = R + self.tol
        d = self.b[:, :2] - self.a[:, :2]
        l2 = np.maximum((d * d).sum(1), 1e-30)
        rel = q[:, None, :] - self.a[None, :, :2]
        bb = (rel * d).sum(2)
        disc = bb * bb - l2 * ((rel * rel).sum(2) - rr * rr)
        sq = np.sqrt(np.maximum(disc, 0.0))
        t1 = np.clip((bb - sq) / l2, 0.0, 1.0)
        t2 = np.clip((bb + sq) / l2, 0.0, 1.0)
        za, dz = self.a[:, 2], self.b[:, 2] - self.a[:, 2]
        lev = np.minimum(za + t1 * dz, za + t2 * dz)
        covered = (disc >= 0) & ((bb + sq) / l2 >= 0) & ((bb - sq) / l2 <= 1)
        top = np.where(covered, lev, np.inf).min(axis=1)
        return np.minimum(top, BOX[1][2])

    def material(self, q: np.ndarray, z: float) -> np.ndarray:
        inside = np.ones(len(q), bool)
        for k in range(2):
            inside &= (q[:, k] > BOX[0][k] + self.tol) & (q[:, k] < BOX[1][k] - self.tol)
        return inside & (self.top(q) > z + self.tol)

    def outer_arcs(self, c: np.ndarray, z: float, f: np.ndarray) -> float:
        """Angular width [rad] of the narrower of the first and last engaged arcs."""
        left = np.array([-f[1], f[0]])
        ph = np.linspace(0.0, math.pi, 1801)
        m = self.material(c + R * (np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left), z)
        if not m.any():
            return math.inf
        edges = np.flatnonzero(np.diff(np.r_[0, m.astype(int), 0]))
        widths = (edges[1::2] - edges[::2]) * (ph[1] - ph[0])
        return float(min(widths[0], widths[-1]))

    def angles(self, c: np.ndarray, z: float, f: np.ndarray) -> tuple[float, float]:
        left = np.array([-f[1], f[0]])

        def mat(ph: np.ndarray) -> np.ndarray:
            q = c + R * (np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left)
            return self.material(q, z)

        return engaged_arc(mat, 20)


def _chords(
    centre: np.ndarray, rho: float, a0: float, a1: float, z0: float, z1: float
) -> list[np.ndarray]:
    """An arc (helix from z0 to z1) as chords within 10 um, as the readers do."""
    half = math.acos(1.0 - 1e-5 / rho)
    n = max(1, math.ceil(abs(a1 - a0) / (2 * half)))
    t = np.linspace(0.0, 1.0, n + 1)
    ang = a0 + t * (a1 - a0)
    return [
        np.array([centre[0] + rho * math.cos(a), centre[1] + rho * math.sin(a), z0 + s * (z1 - z0)])
        for a, s in zip(ang, t, strict=True)
    ]


def _history(rng: np.random.Generator, kind: str) -> list[np.ndarray]:
    """Tip positions of one cut of the history (the first one a plunge point)."""
    z = float(rng.choice(LEVELS))
    p = rng.uniform(-0.015, 0.015, 2)
    ang = rng.uniform(0, 2 * math.pi)
    u = np.array([math.cos(ang), math.sin(ang)])
    if kind == "line":
        q = p + rng.uniform(0.01, 0.03) * u
        return [np.r_[p, z], np.r_[q, z]]
    if kind == "corner":
        q = p + rng.uniform(0.008, 0.02) * u
        turn = rng.choice([-1, 1]) * rng.uniform(math.radians(30), math.radians(150))
        v = np.array([math.cos(ang + turn), math.sin(ang + turn)])
        return [np.r_[p, z], np.r_[q, z], np.r_[q + rng.uniform(0.008, 0.02) * v, z]]
    if kind == "arc":
        rho = rng.uniform(0.003, 0.015)
        sweep = rng.choice([-1, 1]) * rng.uniform(math.radians(60), math.radians(300))
        return _chords(p, rho, ang, ang + sweep, z, z)
    if kind == "helix":
        rho = rng.uniform(0.002, 0.006)
        z0 = z + rng.uniform(0.0005, 0.002)
        return _chords(p, rho, ang, ang + rng.choice([-1, 1]) * 2 * math.pi, z0, z)
    # a ramp from one level down to another
    z0 = float(rng.choice([lv for lv in (*LEVELS, 0.0005) if lv > z]))
    q = p + rng.uniform(0.01, 0.03) * u
    return [np.r_[p, z0], np.r_[q, z]]


def _case(seed: int) -> tuple[np.ndarray, np.ndarray, str]:
    """Tip positions, feed flags and the probe's kind (``"ramp"`` appended where a ramp or
    helix is in the history: the probe may cross a sloped floor)."""
    rng = np.random.default_rng(seed)
    kinds = ("line", "corner", "arc", "helix", "ramp")
    pts = [np.array([0.0, 0.0, 0.02])]
    cut = [False]
    cuts = []
    sloped = False
    for _ in range(int(rng.integers(1, 4))):
        kind = str(rng.choice(kinds))
        h = _history(rng, kind)
        sloped |= kind in ("helix", "ramp")
        pts += [np.r_[h[0][:2], 0.02], h[0]]  # rapid above, plunge
        cut += [False, True]
        pts += h[1:]
        cut += [True] * (len(h) - 1)
        cuts.append(h)
    # the probe: across, along a wall (tangent graze), or at a random place
    lag = 2 * D / 40
    length = 1.5 * lag
    probe = str(rng.choice(["across", "graze", "free"]))
    flat = [h for h in cuts if np.ptp([q[2] for q in h[1:]]) == 0.0]
    if probe == "graze" and not flat:
        probe = "across"
    if probe == "graze":
        h = flat[int(rng.integers(len(flat)))]
        k = int(rng.integers(len(h) - 1))
        a, b = h[k], h[k + 1]
        t = rng.uniform(0.2, 0.8)
        end = a + t * (b - a)
        f = (b - a)[:2] / np.linalg.norm((b - a)[:2])
        z = float(end[2])
    else:
        end = np.r_[rng.uniform(-0.02, 0.02, 2), 0.0]
        ang = rng.uniform(0, 2 * math.pi)
        f = np.array([math.cos(ang), math.sin(ang)])
        z = float(rng.choice(LEVELS)) if probe == "free" else min(float(h[-1][2]) for h in cuts)
    start = np.r_[end[:2] - length * f, z]
    stop = np.r_[end[:2], z]
    pts += [np.r_[start[:2], 0.02], start, stop]
    cut += [False, True, True]
    return np.array(pts), np.array(cut), probe + (" ramp" if sloped else "")


def _exact(
    xyz: np.ndarray, cut: np.ndarray, tol: float, widths: bool = False
) -> tuple[float, float]:
    """Exact (entry, exit) of the probe; ``widths``: (narrowest outer arc, nan) instead."""
    moves = [(xyz[k - 1], xyz[k]) for k in range(1, len(xyz) - 1) if cut[k]]
    f = (xyz[-1] - xyz[-2])[:2]
    ex = Exact(moves, tol)
    if widths:
        return ex.outer_arcs(xyz[-1, :2], float(xyz[-1, 2]), f / np.linalg.norm(f)), math.nan
    return ex.angles(xyz[-1, :2], float(xyz[-1, 2]), f / np.linalg.norm(f))


def _differ(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Largest angle difference [deg]; air is the empty arc: against an arc, its width."""
    if math.isnan(a[0]) and math.isnan(b[0]):
        return 0.0
    if math.isnan(a[0]) or math.isnan(b[0]):
        arc = b if math.isnan(a[0]) else a
        return math.degrees(arc[1] - arc[0])
    return math.degrees(max(abs(a[0] - b[0]), abs(a[1] - b[1])))


#: A case is ill-conditioned when its exact angles move by more than 1 deg as the
#: thin-material tolerance moves by this [m] (a graze, or a floor within 2 um of the
#: tolerance) or an outermost engaged arc is narrower than a cell (a cusp between two
#: earlier cuts). The Z-map's interpolated distance field alone does not decide such
#: cases (its own error at D/40 is about res^2 / 8R = 1.6 um for this 10 mm cutter);
#: the production's exact test where the cells disagree does: they are compared too,
#: and counted so that the sample keeps some.
CONDITION_M = 2e-6
#: Largest error [deg] on any case: the exact test's bisection to 1/8 deg, with margin
#: (the issue's goal is 2 deg; before the exact test a floor crossing the tolerance
#: between cell centres erred by up to 2.9 deg, a cusp narrower than a cell by 112).
TOL_DEG = 0.5


def _compare(seeds: range | list[int], cells: float) -> tuple[list[float], list[str], int]:
    """Errors [deg] of the cutting cases, the cases over :data:`TOL_DEG`, the ill-conditioned."""
    stock = Stock.box(*BOX)
    errs: list[float] = []
    bad: list[str] = []
    ill = 0
    for seed in seeds:
        xyz, cut, probe = _case(seed)
        e = compute_engagement(xyz, cut, D, stock, resolution_m=D / cells)
        exact = _exact(xyz, cut, LEVEL_TOL_M)
        spread = max(
            _differ(exact, _exact(xyz, cut, LEVEL_TOL_M - CONDITION_M)),
            _differ(exact, _exact(xyz, cut, LEVEL_TOL_M + CONDITION_M)),
        )
        if spread > 1.0 or _exact(xyz, cut, LEVEL_TOL_M, widths=True)[0] < D / 40 / R:
            ill += 1
        ours = (float(e.phi_entry[-1]), float(e.phi_exit[-1]))
        err = _differ(ours, exact)
        if err > TOL_DEG:
            bad.append(f"seed {seed} ({probe}): ours {np.degrees(ours)}, exact {np.degrees(exact)}")
        if not math.isnan(exact[0]):
            errs.append(err)
    return errs, bad, ill


@pytest.mark.parametrize("block", range(4))
def test_random_moves_within_half_a_degree_of_the_exact_reference(block: int) -> None:
    errs, bad, ill = _compare(range(block * 40, block * 40 + 40), 40)
    assert not bad, "\n".join(bad)
    assert ill <= 4, ill  # the sample is mostly ordinary cuts
    assert len(errs) >= 20, len(errs)  # most probes cut


@pytest.mark.slow
@pytest.mark.parametrize("cells", [20, 50])
def test_random_moves_converge_with_the_cell(cells: int) -> None:
    """A coarser and a finer cell than the default decide the same cases as finely (up to
    D/53 the probe is still one sample at its end: at most twice the production's lag)."""
    seeds = [s for s in range(40) if (cells, s) not in KNOWN_COARSE]
    errs, bad, _ = _compare(seeds, cells)
    assert not bad, "\n".join(bad)
    assert len(errs) >= 20, len(errs)


#: Known cases over :data:`TOL_DEG` at a cell coarser than the default, as (cells, seed).
#: Tracked here, strictly: the test fails when a case is mended, so its entry can be
#: removed. Seed 7 at D/20 (free ramp over an arc at -6 mm and a corner at -4 mm: 106.56
#: deg against an exact 107.81 after the helix floor fix) was mended by the sweep index
#: (the cells near the probe remembered only the deeper arc; 107.8103 deg now).
KNOWN_COARSE: dict[tuple[int, int], str] = {}


@pytest.mark.slow
@pytest.mark.parametrize(("cells", "seed"), sorted(KNOWN_COARSE))
@pytest.mark.xfail(strict=True, reason="known coarse-cell case, see KNOWN_COARSE")
def test_known_coarse_cell_cases(cells: int, seed: int) -> None:
    _, bad, _ = _compare(range(seed, seed + 1), cells)
    assert not bad, "\n".join(bad)
