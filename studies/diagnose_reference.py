"""Concealed campaigns for the diagnosis study, made by a reference model independent of
:mod:`robolobe.twin.effects`.

What a test lab hands over: hammer tests of a robot that differs from its
file, written as an ordinary campaign that names only the file. Here the
robot differs in two ways, both concealed from the diagnosis:

* **the file is off** (every campaign unless ``file_error=0``): the true
  robot's joint stiffnesses x U(1 - e, 1 + e), dampings x U(1 - 2e, 1 + 2e),
  link and spindle masses x U(1 - e/2, 1 + e/2) (e = 0.1 by default, as the
  transfer study's concealed robots); this is done on the robot description
  here, not with :func:`robolobe.twin.params.apply_parameters`;
* **physics the file leaves out**, assembled *here*: this module builds its
  own augmented mass, stiffness and damping matrices on top of the nominal
  twin's joint-space matrices (:func:`robolobe.twin.system.nominal_system`,
  the robot file's M(q), K, C and TCP Jacobian), and its own FRF by a
  state-space eigen-decomposition with ``V^-1`` residues (not the
  symmetric modal normalisation of :mod:`robolobe.diagnose.twin_model`).
  Nothing of :mod:`robolobe.twin.effects` is used, so the diagnosis's library
  and this reference share no code for the extra physics.

Physics (``Physics.kind``; in brackets the library family that should name it,
"outside" if none):

=============  ==========================================================  ================
kind           model                                                       family
=============  ==========================================================  ================
mass           point mass at the TCP: ``M += m J^T J``                     added_mass
kfactor        a joint's stiffness x factor (on the true robot)            joint_stiffness
dfactor        a joint's damping x factor                                  joint_damping
tool           spring-mass DOF along a TCP axis; ``local``: the mass is     tool_mode
               taken out of the arm (``M -= m J^T J``)
servo          series DOF on a joint's column with stiffness k_s           servo_mode
gravity        ``K_jj += k_j beta |tau_g,j| / 1e4``, own gravity torques    gravity_stiffening
sensor_rot     ``R^T H``                                                   sensor_misalignment
hammer_rot     ``H R``                                                     hammer_direction
gain           ``diag(g) H``                                               sensor_gain
delay          ``H exp(-i w tau)``                                         sensor_delay
tcp_offset     measured point ``p + R d``: ``J = R^T (Jv - [R d]x Jw)``     tcp_offset
absorber       a spring-mass on link 3's COM along world z                 outside
com            link 3's centre of mass moved (file value kept)             outside
link_mass      link 3's mass x factor                                      file_parameters
=============  ==========================================================  ================

Seed-table campaigns (:func:`seed_table_campaign`): the measured modes of the
seed paper's Tables 4 (B) and 7 (C), three postures of five modes in Y,
rebuilt as yy receptances ``sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)``
with 2 % complex log-noise; the postures are those of the seed's Tables 3
and 6.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe.campaign import Campaign, PostureFRF
from robolobe.diagnose import DiagnoseSettings, Diagnosis, diagnose
from robolobe.robots import RigidBody, Robot, load_robot
from robolobe.robots.transforms import rotation_from_zyx
from robolobe.twin.designs import TESTED_RANGES_DEG, space_filling_design
from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test
from robolobe.twin.system import nominal_system

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: Library family that should name each kind (None: outside the library).
FAMILY: dict[str, str | None] = {
    "mass": "added_mass",
    "kfactor": "joint_stiffness",
    "dfactor": "joint_damping",
    "tool": "tool_mode",
    "servo": "servo_mode",
    "gravity": "gravity_stiffening",
    "sensor_rot": "sensor_misalignment",
    "hammer_rot": "hammer_direction",
    "gain": "sensor_gain",
    "delay": "sensor_delay",
    "tcp_offset": "tcp_offset",
    "absorber": None,
    "com": None,
    "link_mass": "file_parameters",
}
#: Families a file calibration may stand for (its parameters hold them).
CALIBRATION_EQUIVALENT = ("joint_stiffness", "joint_damping", "file_parameters")


@dataclass(frozen=True)
class Physics:
    """One concealed difference between the robot and its file.

    Parameters
    ----------
    kind : str
        A key of :data:`FAMILY`.
    params : tuple of (str, value)
        Its parameters (see the module table).
    """

    kind: str
    params: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if self.kind not in FAMILY:
            raise ValueError(f"kind: expected one of {sorted(FAMILY)}, found {self.kind!r}")

    def get(self, name: str, default: Any = None) -> Any:
        """A parameter."""
        return dict(self.params).get(name, default)

    @property
    def family(self) -> str | None:
        """Library family that should name it (None: outside the library)."""
        return FAMILY[self.kind]


def P(kind: str, **kw: Any) -> Physics:
    """``Physics(kind, params)`` from keywords."""
    return Physics(kind, tuple(sorted(kw.items())))


# ------------------------------------------------------------ the true robot
def true_robot(robot: Robot, physics: Sequence[Physics], file_error: float, seed: int) -> Robot:
    """The robot the campaign is measured on: the file with its errors and file-level physics."""
    rng = np.random.default_rng(10_000 + seed)
    k = np.array(robot.stiffness, dtype=float)
    c = np.array(robot.damping, dtype=float)
    e = float(file_error)
    k *= rng.uniform(1 - e, 1 + e, 6)
    c *= rng.uniform(1 - 2 * e, 1 + 2 * e, 6)
    ms = rng.uniform(1 - e / 2, 1 + e / 2, 7)
    for p in physics:
        if p.kind == "kfactor":
            k[p.get("joint") - 1] *= p.get("factor")
        elif p.kind == "dfactor":
            c[p.get("joint") - 1] *= p.get("factor")
        elif p.kind == "link_mass":
            ms[p.get("link", 3) - 1] *= p.get("factor")
    out = robot.with_stiffness(k).with_damping(c)
    joints = []
    for i, jt in enumerate(out.joints):
        b = jt.body
        com = np.array(b.com_m, dtype=float)
        for p in physics:
            if p.kind == "com" and p.get("link", 3) == i + 1:
                com = com + np.asarray(p.get("offset_m"), dtype=float)
        joints.append(
            dataclasses.replace(jt, body=RigidBody(b.mass_kg * ms[i], com, b.inertia_kgm2 * ms[i]))
        )
    out = out.replace(joints=tuple(joints))
    ee = out.end_effector
    if ee is not None:
        out = out.replace(
            end_effector=RigidBody(ee.mass_kg * ms[6], ee.com_m, ee.inertia_kgm2 * ms[6])
        )
    return out


# ------------------------------------------------------------ assembly
def _augment(
    M: FloatArray, K: FloatArray, C: FloatArray, J: FloatArray, cols: list[tuple[Any, ...]]
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Append DOFs: each ``(m_col (n,), m_self, k, zeta, j_col (3,)[, m_damp])``, coupling m_col.

    The dashpot is ``2 zeta sqrt(k m_damp)``, ``m_damp`` = ``m_self`` unless given.
    """
    for m_col, m_self, k, zeta, j_col, *m_damp in cols:
        n = M.shape[0]
        M2 = np.zeros((n + 1, n + 1))
        M2[:n, :n] = M
        M2[:n, n] = M2[n, :n] = m_col
        M2[n, n] = m_self
        K2 = np.zeros_like(M2)
        K2[:n, :n] = K
        K2[n, n] = k
        C2 = np.zeros_like(M2)
        C2[:n, :n] = C
        C2[n, n] = 2.0 * zeta * np.sqrt(k * (m_damp[0] if m_damp else m_self))
        J2 = np.concatenate([J, np.asarray(j_col, dtype=float)[:, None]], axis=1)
        M, K, C, J = M2, K2, C2, J2
    return M, K, C, J


def _frf(M: FloatArray, K: FloatArray, C: FloatArray, J: FloatArray, w: FloatArray) -> ComplexArray:
    """``J (K - w^2 M + i w C)^-1 J^T`` by a state-space eigen-decomposition, (n_freq, 3, 3)."""
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ K
    A[n:, n:] = -Minv @ C
    B = np.zeros((2 * n, 3))
    B[n:] = Minv @ J.T
    lam, V = np.linalg.eig(A)
    left = np.concatenate([J, np.zeros_like(J)], axis=1) @ V  # (3, 2n)
    right = np.linalg.solve(V, B)  # (2n, 3)
    g = 1.0 / (1j * w[:, None] - lam[None, :])  # (n_freq, 2n)
    return np.einsum("fr,ir,rj->fij", g, left, right, optimize=True)


def reference_receptance(
    robot: Robot, physics: Sequence[Physics], q_rad: FloatArray, freq_hz: FloatArray
) -> ComplexArray:
    """Receptance of the true robot (already holding its file-level changes) with ``physics``.

    Parameters
    ----------
    robot : Robot
        The true robot (:func:`true_robot`).
    physics : sequence of Physics
    q_rad : ndarray, shape (n, 6)
    freq_hz : ndarray, shape (n_freq,)

    Returns
    -------
    ndarray, shape (n, n_freq, 3, 3), complex [m/N]
    """
    sm = nominal_system(robot, q_rad)
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    out = np.empty((q_rad.shape[0], w.size, 3, 3), dtype=complex)
    g_vec = np.array([0.0, 0.0, -9.81])
    for i in range(q_rad.shape[0]):
        M = sm.M[i].copy()
        K = np.array(sm.K[i] if sm.K.ndim == 3 else sm.K, dtype=float)
        C = np.array(sm.C[i] if sm.C.ndim == 3 else sm.C, dtype=float)
        R = sm.tcp_rotation[i]
        Jv, Jw = sm.tcp_jv[i], sm.tcp_jw[i]  # world (3, 6)
        J = R.T @ Jv  # TCP frame
        J_meas = J.copy()
        cols: list[tuple[Any, ...]] = []
        for p in physics:
            if p.kind == "mass":
                M = M + p.get("mass_kg") * J.T @ J
            elif p.kind == "gravity":
                tau = np.einsum("b,bkj,k->j", sm.bodies.mass_kg, sm.bodies.jv[i], g_vec)
                K = K + np.diag(robot.stiffness * p.get("beta") * np.abs(tau) / 1e4)
            elif p.kind == "tcp_offset":
                r = R @ np.asarray(p.get("offset_m"), dtype=float)
                J_meas = R.T @ (Jv + np.cross(Jw.T, r).T)  # v + w x r per column
        for p in physics:
            if p.kind == "tool":
                m = p.get("mass_kg")
                e = np.eye(3)["xyz".index(p.get("direction"))]
                if p.get("local", False):
                    M = M - m * J.T @ J
                M = M + m * J.T @ J
                k = m * (2 * np.pi * p.get("f_hz")) ** 2
                cols.append((m * J.T @ e, m, k, p.get("zeta"), e))
            elif p.kind == "servo":
                j = p.get("joint") - 1
                # the servo spring turns the rotor (reflected inertia) and, through the gear
                # spring, the arm: the arm turns by q_j + s, the rotor by s
                m_self = M[j, j] + p.get("rotor_kgm2")
                # the loop's dashpot acts on the motor: the rotor's own oscillator's zeta
                cols.append(
                    (
                        M[:, j].copy(),
                        m_self,
                        p.get("k_Nm_per_rad"),
                        p.get("zeta"),
                        J_meas[:, j],
                        p.get("rotor_kgm2"),
                    )
                )
            elif p.kind == "absorber":
                bi = list(sm.bodies.names).index("link3")
                jv = sm.bodies.jv[i, bi]  # (3, 6) world
                ez = np.array([0.0, 0.0, 1.0])
                m = p.get("mass_kg")
                M = M + m * jv.T @ jv
                k = m * (2 * np.pi * p.get("f_hz")) ** 2
                cols.append((m * jv.T @ ez, m, k, p.get("zeta"), np.zeros(3)))
        # coupling columns were computed against the robot block only; pad to the current size
        Mr, Kr, Cr, Jr = M, K, C, J_meas
        for col in cols:
            m_col = np.zeros(Mr.shape[0])
            m_col[: col[0].size] = col[0]
            Mr, Kr, Cr, Jr = _augment(Mr, Kr, Cr, Jr, [(m_col, *col[1:])])
        H = _frf(Mr, Kr, Cr, Jr, w)
        for p in physics:
            if p.kind == "sensor_rot":
                Rs = rotation_from_zyx([p.get("rz", 0.0), p.get("ry", 0.0), p.get("rx", 0.0)])
                H = Rs.T @ H
            elif p.kind == "hammer_rot":
                Rh = rotation_from_zyx([p.get("rz", 0.0), p.get("ry", 0.0), p.get("rx", 0.0)])
                H = H @ Rh
            elif p.kind == "gain":
                H = np.asarray(p.get("gain"), dtype=float)[:, None] * H
            elif p.kind == "delay":
                H = H * np.exp(-1j * w * p.get("delay_s"))[:, None, None]
        out[i] = H
    return out


# ------------------------------------------------------------ cases
@dataclass(frozen=True)
class Case:
    """One concealed campaign.

    Parameters
    ----------
    robot : str
        ``"A"``, ``"B"``, ``"C"`` or a robot file.
    physics : tuple of Physics
        What the file leaves out (empty: a null campaign, up to the file errors).
    label : str
        Short description for tables.
    file_error : float
        Relative spread of the file's errors (0: the file is exact).
    n_postures : int
    seed : int
    noise : float
        Test noise x the seed-like default.
    double_hits : float
        Probability of a (kept) double hit per impact.
    """

    robot: str
    physics: tuple[Physics, ...]
    label: str
    file_error: float = 0.1
    n_postures: int = 30
    seed: int = 0
    noise: float = 1.0
    double_hits: float = 0.0

    @property
    def truths(self) -> tuple[str, ...]:
        """Library families that are really there (``file_parameters`` for file errors)."""
        fams = [p.family for p in self.physics if p.family is not None]
        if self.file_error > 0:
            fams.append("file_parameters")
        return tuple(dict.fromkeys(fams))

    @property
    def outside(self) -> bool:
        """Whether physics outside the library is concealed."""
        return any(p.family is None for p in self.physics)

    @property
    def acceptable(self) -> tuple[str, ...]:
        """Families whose naming is not a false claim."""
        t = set(self.truths)
        if t & set(CALIBRATION_EQUIVALENT):
            t |= set(CALIBRATION_EQUIVALENT)
        return tuple(sorted(t))

    @property
    def required(self) -> tuple[str, ...]:
        """In-library physics the diagnosis must name (the file errors aside)."""
        return tuple(p.family for p in self.physics if p.family not in (None,))  # type: ignore[misc]


def make_campaign(case: Case) -> Campaign:
    """Simulate the hammer campaign of ``case`` (seed test, names only the file)."""
    rng = np.random.default_rng(case.seed)
    robot = load_robot(case.robot)
    truth = true_robot(robot, case.physics, case.file_error, case.seed)
    design = space_filling_design(
        robot, case.n_postures, rng, ranges_deg=TESTED_RANGES_DEG.get(case.robot)
    )
    ids = tuple(str(x) for x in design["posture_id"])
    q = np.radians(design[[f"q{i}_deg" for i in range(1, 7)]].to_numpy(dtype=float))
    s = HammerTestSettings()
    s = s.replace(
        force_noise_n=s.force_noise_n * case.noise,
        accel_noise_m_per_s2=s.accel_noise_m_per_s2 * case.noise,
        double_hit_probability=case.double_hits,
        reject_double_hits=case.double_hits == 0.0,
    )
    H = reference_receptance(truth, case.physics, q, s.fine_freq_hz)
    res = simulate_hammer_test(H, rng=rng, settings=s)
    frfs = tuple(PostureFRF(res.freq_hz, res.H1[k]) for k in range(len(ids)))
    return Campaign(
        robot=case.robot,
        posture_ids=ids,
        q_rad=q,
        frfs=frfs,
        notes="simulated hammer test (studies/diagnose_reference.py)",
        test={
            "sample_rate_hz": s.sample_rate_hz,
            "duration_s": s.duration_s,
            "impacts": s.impacts,
            "window_end": s.window_end,
        },
    )


# ------------------------------------------------------------ seed tables
#: Seed Table 4 (B) and 7 (C): per posture, modes (f [Hz], zeta [%], k [1e5 N/m]) in Y (EMA).
SEED_TABLES: dict[str, dict[str, Any]] = {
    "B": {
        "q_deg": [
            [-2, 21, -27, 5, 1, -29],
            [-60, 50, -120, 115, -66, -197],
            [23, -28, -101, -82, 124, 168],
        ],
        "modes": [
            [
                (7.352, 0.872, 1.34682),
                (12.056, 2.138, 6.06784),
                (14.530, 0.224, 17.96839),
                (19.365, 3.643, 15.46110),
                (31.493, 1.533, 10.00344),
            ],
            [
                (6.965, 1.020, 1.32453),
                (11.263, 0.407, 0.74342),
                (14.730, 6.895, 4.56509),
                (23.769, 2.334, 26.90947),
                (30.273, 2.932, 14.55168),
            ],
            [
                (7.48, 1.493, 1.27141),
                (10.564, 2.412, 1.07695),
                (13.602, 1.024, 4.56509),
                (21.070, 3.582, 15.87799),
                (31.453, 1.107, 19.92689),
            ],
        ],
    },
    "C": {
        "q_deg": [
            [39, 8, 8, 98, -18, -30],
            [47, -10, 36, 74, -89, -13],
            [-3, 48, 20, -129, -57, -2],
        ],
        "modes": [
            [
                (13.7, 1.960, 1.27141),
                (16.2, 1.050, 0.37339),
                (22.3, 1.080, 13.78216),
                (24.1, 0.160, 12.94221),
                (25.3, 0.870, 25.30907),
            ],
            [
                (11.4, 1.720, 1.23723),
                (12.4, 0.012, 0.35768),
                (21.2, 3.290, 25.08313),
                (22.6, 0.370, 15.87798),
                (25.2, 1.720, 22.89233),
            ],
            [
                (11.8, 1.460, 1.19254),
                (12.7, 1.320, 0.32806),
                (20.1, 2.830, 15.58686),
                (20.8, 0.430, 22.89233),
                (25.5, 0.500, 27.24097),
            ],
        ],
    },
}


_TABLE = {"B": "4", "C": "7"}


def seed_table_campaign(robot: str, *, seed: int = 0, noise: float = 0.02) -> Campaign:
    """The seed's measured Y modes of ``robot`` ("B" or "C") as a yy-only campaign."""
    tab = SEED_TABLES[robot]
    rng = np.random.default_rng(seed)
    f = np.arange(0.0, 512.0 + 1e-9, 0.25)
    w = 2 * np.pi * f
    frfs = []
    for modes in tab["modes"]:
        H = np.full((f.size, 3, 3), np.nan + 0j)
        h = np.zeros(f.size, complex)
        for fr, z, k in modes:
            wr = 2 * np.pi * fr
            h += (wr**2 / (k * 1e5)) / (wr**2 - w**2 + 2j * (z / 100) * wr * w)
        h *= np.exp(noise * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)))
        H[:, 1, 1] = h
        frfs.append(PostureFRF(f, H))
    return Campaign(
        robot=robot,
        posture_ids=tuple(f"T{i + 1}" for i in range(len(frfs))),
        q_rad=np.radians(np.array(tab["q_deg"], dtype=float)),
        frfs=tuple(frfs),
        notes=f"seed paper's measured modes of {robot} (Table {_TABLE[robot]}), rebuilt",
    )


# ------------------------------------------------------------ running and scoring
@dataclass(frozen=True)
class CaseResult:
    """Outcome of one case (one row of the study table)."""

    case: Case
    verdict: str
    named: tuple[str, ...]
    closest: tuple[str, ...]
    unexplained: bool
    misfit_x_noise: float
    nrmse_x_noise: float
    frac_before: float
    frac_after: float
    nrmse_before: float
    nrmse_after: float
    seconds: float
    summary: str
    params: dict[str, float] = field(default_factory=dict)
    cpu_seconds: float = float("nan")

    @property
    def false_claim(self) -> bool:
        """A named family that is not there, or a claim whose held-out misfit stays > 2x noise."""
        if self.unexplained:
            return False
        wrong = [n for n in self.named if n not in self.case.acceptable]
        return bool(wrong) or (
            bool(self.named) and max(self.misfit_x_noise, self.nrmse_x_noise) > 2.0
        )

    @property
    def found_all(self) -> bool:
        """Every required in-library family named (file errors may be named or not)."""
        req = set(self.case.required)
        got = set(self.named)
        if req & set(CALIBRATION_EQUIVALENT) and got & set(CALIBRATION_EQUIVALENT):
            req -= set(CALIBRATION_EQUIVALENT)
        return req <= got and not self.unexplained


def run_case(
    case: Case, *, settings: DiagnoseSettings | None = None
) -> tuple[CaseResult, Diagnosis]:
    """Simulate and diagnose one case (the diagnosis is told nothing)."""
    camp = make_campaign(case)
    t0, c0 = time.perf_counter(), time.process_time()
    d = diagnose(camp, robot=load_robot(case.robot), settings=settings)
    return _result(case, d, time.perf_counter() - t0, time.process_time() - c0), d


def _result(case: Case, d: Diagnosis, seconds: float, cpu_seconds: float) -> CaseResult:
    fw = d.forward
    params = {}
    for st in fw.steps:
        for p, v in zip(st.candidate.params, st.params, strict=True):
            params[f"{st.label}.{p.name}"] = float(v)
    return CaseResult(
        case=case,
        verdict=d.verdict,
        named=d.named,
        closest=tuple(st.label for st in fw.steps),
        unexplained=d.unexplained,
        misfit_x_noise=fw.noise.misfit_x_noise,
        nrmse_x_noise=fw.noise.nrmse_x_noise,
        frac_before=d.fit_before.frac_mean,
        frac_after=d.fit_after.frac_mean,
        nrmse_before=d.fit_before.nrmse_mean,
        nrmse_after=d.fit_after.nrmse_mean,
        seconds=seconds,
        summary=d.summary,
        params=params,
        cpu_seconds=cpu_seconds,
    )


def run_seed_table(
    robot: str, *, settings: DiagnoseSettings | None = None
) -> tuple[CaseResult, Diagnosis]:
    """Diagnose the seed-table campaign of ``robot`` (the truth is unknown: a real robot)."""
    camp = seed_table_campaign(robot)
    t0, c0 = time.perf_counter(), time.process_time()
    d = diagnose(camp, robot=load_robot(robot), settings=settings)
    case = Case(
        robot, (), f"seed Table {'4' if robot == 'B' else '7'}", file_error=1.0, n_postures=3
    )
    return _result(case, d, time.perf_counter() - t0, time.process_time() - c0), d


def standard_cases(
    robots: Sequence[str] = ("B", "C"),
    *,
    n_postures: int = 30,
    seeds: Sequence[int] = (0,),
    file_error: float = 0.1,
    groups: Sequence[str] = ("single", "pair", "outside", "null"),
) -> list[Case]:
    """The study's cases: in-library effects (also above 40 Hz), pairs, outside physics, nulls.

    Magnitudes are realistic for a lab (spindle brackets 30-90 Hz, a few kg
    of sensors and adapters, joint stiffness off by 15-25 %, a sensor or
    hammer a few degrees off, a channel 10 % off).
    """
    deg = np.pi / 180
    single = [
        ("+5 kg at the tool", (P("mass", mass_kg=5.0),)),
        ("joint 3 stiffness x0.8", (P("kfactor", joint=3, factor=0.8),)),
        ("tool mode 31 Hz y", (P("tool", f_hz=31.0, zeta=0.03, mass_kg=4.0, direction="y"),)),
        (
            "tool mode 63 Hz x, local",
            (P("tool", f_hz=63.0, zeta=0.03, mass_kg=15.0, direction="x", local=True),),
        ),
        ("tool mode 72 Hz z", (P("tool", f_hz=72.0, zeta=0.02, mass_kg=8.0, direction="z"),)),
        (
            "servo holding mode joint 1",
            (P("servo", joint=1, k_Nm_per_rad=3e5, zeta=0.1, rotor_kgm2=40.0),),
        ),
        ("gravity stiffening 0.3", (P("gravity", beta=0.3),)),
        ("sensor rotated 3 deg", (P("sensor_rot", rz=3 * deg, rx=1 * deg),)),
        ("hammer 10 deg off", (P("hammer_rot", ry=10 * deg),)),
        ("y channel +12 %", (P("gain", gain=(1.0, 1.12, 1.0)),)),
        ("delay 2 ms", (P("delay", delay_s=0.002),)),
        ("TCP 5 cm further out", (P("tcp_offset", offset_m=(0.0, 0.0, 0.05)),)),
    ]
    pair = [
        ("+6 kg and sensor rotated", (P("mass", mass_kg=6.0), P("sensor_rot", rz=4 * deg))),
        (
            "gravity 0.3 and tool mode 24 Hz",
            (P("gravity", beta=0.3), P("tool", f_hz=24.0, zeta=0.02, mass_kg=5.0, direction="x")),
        ),
        (
            "tool mode 45 Hz and y channel +10 %",
            (
                P("tool", f_hz=45.0, zeta=0.03, mass_kg=6.0, direction="y"),
                P("gain", gain=(1.0, 1.1, 1.0)),
            ),
        ),
    ]
    outside = [
        ("absorber on link 3 at 18 Hz", (P("absorber", mass_kg=25.0, f_hz=18.0, zeta=0.02),)),
        ("link 3 COM moved 15 cm", (P("com", link=3, offset_m=(0.15, 0.0, 0.0)),)),
    ]
    null = [("null", ()), ("null, double hits", ()), ("null, 3x noise", ())]
    out: list[Case] = []
    for rb in robots:
        for s in seeds:
            if "single" in groups:
                out += [Case(rb, ph, lab, file_error, n_postures, s) for lab, ph in single]
                out += [
                    Case(rb, single[i][1], single[i][0] + ", exact file", 0.0, n_postures, s)
                    for i in (2, 3)
                ]
            if "pair" in groups:
                out += [Case(rb, ph, lab, file_error, n_postures, s) for lab, ph in pair]
            if "outside" in groups:
                out += [Case(rb, ph, lab, file_error, n_postures, s) for lab, ph in outside]
            if "null" in groups:
                out += [
                    Case(rb, (), "null, exact file", 0.0, n_postures, 100 + s),
                    Case(rb, (), "null, double hits", 0.0, n_postures, 200 + s, double_hits=0.3),
                    Case(rb, (), "null, 3x noise", 0.0, n_postures, 300 + s, noise=3.0),
                ]
    del null
    return out


def results_frame(results: Sequence[CaseResult]) -> pd.DataFrame:
    """One row per case."""
    return pd.DataFrame(
        [
            {
                "robot": r.case.robot,
                "case": r.case.label,
                "file_error": r.case.file_error,
                "truths": "+".join(r.case.truths) or "none",
                "outside": r.case.outside,
                "verdict": r.verdict,
                "named": "+".join(r.named) or "-",
                "closest": "; ".join(r.closest) or "-",
                "found_all": r.found_all,
                "false_claim": r.false_claim,
                "unexplained": r.unexplained,
                "misfit_x_noise": r.misfit_x_noise,
                "nrmse_x_noise": r.nrmse_x_noise,
                "frac_before": r.frac_before,
                "frac_after": r.frac_after,
                "nrmse_before": r.nrmse_before,
                "nrmse_after": r.nrmse_after,
                "seconds": r.seconds,
                "cpu_seconds": r.cpu_seconds,
            }
            for r in results
        ]
    )


def study_tables(df: pd.DataFrame) -> dict[str, pd.DataFrame]:
    """Summary: detection of in-library physics, false claims, nulls, outside physics."""
    if df.empty:
        return {"cases": df}
    lib = df[(df["truths"] != "none") & (df["truths"] != "file_parameters") & ~df["outside"]]
    nul = df[df["case"].str.startswith("null")]
    out = df[df["outside"]]
    summary = pd.DataFrame(
        {
            "cases": [len(lib), len(nul), len(out), len(df)],
            "found_all": [int(lib["found_all"].sum()), None, None, None],
            "false_claims": [
                int(lib["false_claim"].sum()),
                int(nul["false_claim"].sum()),
                int(out["false_claim"].sum()),
                int(df["false_claim"].sum()),
            ],
            "unexplained": [
                int(lib["unexplained"].sum()),
                int(nul["unexplained"].sum()),
                int(out["unexplained"].sum()),
                int(df["unexplained"].sum()),
            ],
        },
        index=["in-library physics", "nulls", "outside the library", "all"],
    )
    return {"cases": df, "summary": summary}


def study_summary(df: pd.DataFrame) -> dict[str, Any]:
    """Per-robot figures of the README row and one record per case (for a JSON file).

    Per robot: ``in_library_named`` / ``in_library_cases`` (every in-library
    effect of a case named), ``pairs_named`` / ``pairs``, ``false_claims`` /
    ``cases``, ``null_false_discoveries`` / ``nulls`` (a verdict other than
    ``none``), ``outside_unexplained`` / ``outside`` (physics outside the
    library left ``unexplained``; the others are listed with their verdicts),
    ``cpu_seconds_median`` / ``_max`` (the diagnosis in one thread).

    Parameters
    ----------
    df : DataFrame
        :func:`results_frame` rows (read back from ``cases.csv`` too).
    """
    per_robot: dict[str, Any] = {}
    for rb in dict.fromkeys(df["robot"]):
        d = df[df["robot"] == rb]
        lib = d[(d["truths"] != "none") & (d["truths"] != "file_parameters") & ~d["outside"]]
        pairs = lib[lib["case"].str.contains(" and ")]
        nul = d[d["case"].str.startswith("null")]
        out = d[d["outside"]]
        per_robot[str(rb)] = {
            "cases": len(d),
            "in_library_cases": len(lib),
            "in_library_named": int(lib["found_all"].astype(bool).sum()),
            "missed": [
                {"case": r.case, "verdict": r.verdict, "misfit_x_noise": float(r.misfit_x_noise)}
                for r in lib[~lib["found_all"].astype(bool)].itertuples()
            ],
            "pairs": len(pairs),
            "pairs_named": int(pairs["found_all"].astype(bool).sum()),
            "false_claims": int(d["false_claim"].astype(bool).sum()),
            "nulls": len(nul),
            "null_false_discoveries": int((nul["verdict"] != "none").sum()),
            "outside": len(out),
            "outside_unexplained": int(out["unexplained"].astype(bool).sum()),
            "outside_verdicts": {
                str(r.case): {"verdict": r.verdict, "misfit_x_noise": float(r.misfit_x_noise)}
                for r in out.itertuples()
            },
            "cpu_seconds_median": float(d["cpu_seconds"].median()),
            "cpu_seconds_max": float(d["cpu_seconds"].max()),
        }
    cases = [
        {k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}
        for row in df.to_dict(orient="records")
    ]
    return {"per_robot": per_robot, "cases": cases}


def _yes(v: Any) -> str:
    return "yes" if bool(v) else "no"


def markdown_tables(df: pd.DataFrame) -> str:
    """The README's tables: totals per robot, then one row per case (Markdown).

    Parameters
    ----------
    df : DataFrame
        :func:`results_frame` rows (read back from ``cases.csv`` too).
    """
    robots = list(dict.fromkeys(df["robot"]))
    lines = [
        "| | "
        + " | ".join(f"robot {rb} ({(df['robot'] == rb).sum()} cases)" for rb in robots)
        + " |"
    ]
    lines.append("|---" * (len(robots) + 1) + "|")

    def row(name: str, fn: Callable[[pd.DataFrame], str]) -> None:
        lines.append(f"| {name} | " + " | ".join(fn(df[df["robot"] == rb]) for rb in robots) + " |")

    def lib(d: pd.DataFrame) -> pd.DataFrame:
        keep = (d["truths"] != "none") & (d["truths"] != "file_parameters") & ~d["outside"]
        return d[keep]

    def found(d: pd.DataFrame) -> str:
        lb = lib(d)
        miss = lb[~lb["found_all"].astype(bool)]
        txt = f"**{int(lb['found_all'].sum())} of {len(lb)}**"
        if len(miss):
            txt += "; missed: " + ", ".join(
                f"{r.case} ({r.verdict}, {r.misfit_x_noise:.1f}x)" for r in miss.itertuples()
            )
        return txt

    def pairs(d: pd.DataFrame) -> str:
        pr = lib(d)[lib(d)["case"].str.contains(" and ")]  # the two-effect cases
        return f"{int(pr['found_all'].sum())} of {len(pr)}"

    def nulls(d: pd.DataFrame) -> str:
        nl = d[d["case"].str.startswith("null")]
        bad = nl[nl["verdict"] != "none"]
        return f"{len(bad)} of {len(nl)}"

    def outside(d: pd.DataFrame) -> str:
        od = d[d["outside"]]
        return "; ".join(
            f"{r.case}: `{r.verdict}` ({r.misfit_x_noise:.1f}x)" for r in od.itertuples()
        )

    def times(d: pd.DataFrame) -> str:
        cpu = d["cpu_seconds"] if "cpu_seconds" in d else pd.Series(dtype=float)
        return (
            f"{d['seconds'].median():.0f} s wall, {cpu.median():.0f} s CPU "
            f"(max {cpu.max():.0f} s CPU)"
        )

    row("in-library physics named (goal 95 %)", found)
    row("both effects of a pair named", pairs)
    row("false claims", lambda d: f"**{int(d['false_claim'].sum())} of {len(d)}**")
    row("false discoveries on nulls", nulls)
    row("outside the library", outside)
    row("median per campaign", times)
    for rb in robots:
        d = df[df["robot"] == rb]
        lines += [
            "",
            f"| case (robot {rb}, file off ~10 % unless said) | verdict | named (or closest, if "
            "unexplained) | all in-library named | false claim | held-out misfit / noise (RMS, "
            "NRMSE) | FRAC before -> after | wall s | CPU s |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in d.itertuples():
            cpu = getattr(r, "cpu_seconds", float("nan"))
            lines.append(
                f"| {r.case} | {r.verdict} | {r.closest} | {_yes(r.found_all)} | "
                f"{_yes(r.false_claim)} | {r.misfit_x_noise:.1f}, {r.nrmse_x_noise:.1f} | "
                f"{r.frac_before:.3f} -> {r.frac_after:.3f} | {r.seconds:.0f} | {cpu:.0f} |"
            )
    return "\n".join(lines)


def run_study(
    cases: Sequence[Case],
    *,
    settings: DiagnoseSettings | None = None,
    progress: Callable[[int, int, CaseResult], None] | None = None,
) -> list[CaseResult]:
    """Diagnose every case in turn."""
    out = []
    for i, c in enumerate(cases):
        r, _ = run_case(c, settings=settings)
        out.append(r)
        if progress is not None:
            progress(i + 1, len(cases), r)
    return out
