"""Job files (``format = "robolobe-job/1"``): what to cut, with what, on which robot.

A job file is TOML with the unit in every key name. :func:`load_job` reads
and validates it (pydantic at the file edge) and returns a :class:`Job` in SI
units and radians. Every problem raises :class:`~robolobe.errors.InputError`
naming the file and the key, e.g. ``job.toml: spindle.power_kW: expected a
positive number, found -3``. Unknown keys are allowed; those that look like a
typo of a known key are logged as warnings. Relative file names inside a job
(robot file, model file) are taken relative to the job file.

Example (all keys; defaults shown where a key is optional)::

    format = "robolobe-job/1"
    name = "pocket in 7075"

    [robot]
    name = "A"                   # "A" | "B" | "C" | path of a robot TOML
    model = "twin"               # "twin" (default: the robot file's own modes) | "builtin"
                                 # (the shipped network of A, B, C) | a tl model file
    tool_rotation_deg = 0.0      # rotation of the TCP x axis about the tool axis
    tool_rotation = "fixed"      # "fixed" | "stiffest" (search the range below)
    tool_rotation_range_deg = [-90.0, 90.0]
    tool_rotation_step_deg = 30.0

    [placement]                  # workpiece (path) frame in the robot base frame
    xyz_m = [1.6, 0.0, 0.2]
    zyx_deg = [0.0, 0.0, 0.0]    # R = Rz(a) Ry(b) Rx(c)

    [tool]
    diameter_mm = 20.0
    teeth = 3
    helix_deg = 30.0
    stickout_mm = 60.0
    corner_radius_mm = 0.0       # 0: flat end mill (the only shape [stock] engagement
                                 # models); D/2: ball end; between: bull nose
    [[tool.modes]]               # spindle/holder/tool modes, TCP frame
    dir = "xy"                   # "x" | "y" | "xy" (both, symmetric spindle)
    f_hz = 1900.0
    zeta = 0.03
    k_N_per_m = 2.5e7

    [material]
    name = "Al7075-T6"           # from the built-in table, or give the coefficients:
    # Kt_N_per_mm2 = 767.0       # tangential cutting coefficient
    # Kr = 0.22                  # radial / tangential (or Kn_N_per_mm2)

    [cut]
    radial_width_mm = 10.0       # or immersion = 0.5 (a_e / D)
    milling = "down"             # "down" | "up"
    feed_per_tooth_mm = 0.1      # used where the program states no F and S
    feed_per_tooth_from = "program"  # "program": the program's own chip load (F / (S N))
                                 # where it states one; "job": feed_per_tooth_mm everywhere
    max_feed_mm_per_min = 20000  # optional cap on the feed rate (robot path speed; default
                                 # the robot file's max_path_speed_mm_per_s, else 1 m/s)
    vc_min_m_per_min = 200.0     # optional cutting-speed range (vc = pi D n / 1000);
    vc_max_m_per_min = 2500.0    #   default: the material table's (carbide)
    feed_per_tooth_min_mm = 0.05 # optional chip-load range; default: the material table's
    feed_per_tooth_max_mm = 0.25
    rapid_feed_mm_per_min = 30000
    programmed_rpm = 18000       # optional: used where the path has no S word
    stock_depth_mm = 12.0        # optional: total depth to remove (all passes), for
                                 # per-part times in compare

    [spindle]
    rpm_min = 6000
    rpm_max = 24000
    power_kW = 15.0
    torque_Nm = 12.0

    [plan]
    safety_factor = 1.3          # depth <= a_lim / safety_factor
    depth_min_mm = 0.1
    depth_max_mm = 10.0
    speed = "scheduled"          # "scheduled" | "constant"
    max_rate_rpm_per_s = 2000    # or max_rate_rpm_per_mm (at most one; none: free)
    robust = false               # plan on the lower bound of the prediction spread
                                 # (unset: robust when robot.model carries a calibrated
                                 # spread, i.e. a `robolobe transfer --robot R` model)
    k_sigma = 2.0                # width of that bound in standard deviations
    spread_f_pct = 0.5           # 1-sigma spread robust plans assume where the mode
    spread_zeta_pct = 10.0       #   source has none (the twin): frequency, damping,
    spread_k_pct = 5.0           #   stiffness; a key set here overrides the source's
    n_rpm = 300                  # speed grid of the lobes
    dynamics_tol_pct = 0.3       # waypoints whose modes agree within this share lobes

    [stock]                      # optional: the raw workpiece (workpiece frame); one of
    box_min_mm = [-60.0, -40.0, -10.0]   # a box: min and max corners, or
    box_max_mm = [60.0, 40.0, 0.0]
    # outline_mm = [[0, 0], [120, 0], [120, 80], [0, 80]]  # an extruded outline
    # z_range_mm = [-10.0, 0.0]          #   with its bottom and top
    resolution_mm = 0.5          # Z-map cell (default tool diameter / 40; at most / 10);
                                 # no [stock] or only this key: the default stock
                                 # (cutting region grown by the tool radius, top Z = 0)

    [path]                       # toolpath reader options (optional; each reader takes
                                 # those that apply to its format; CLI flags override)
    units = "auto"               # "auto" | "mm" | "inch": G-code/APT without G20/G21/UNITS
    tool_direction = "z"         # "z" | "x": KRL/RAPID tool-frame axis along the working direction
    coordinates = "workpiece"    # "workpiece" | "machine": APT MSYS, KRL $BASE, RAPID wobjdata
    rotary_axes = "auto"         # "auto" | "head" | "table": G-code A/B/C words
    circle_axis = "auto"         # "auto" | "cw" | "ccw": APT CIRCLE sense about i,j,k
                                 # (NX: cw, CATIA: ccw; auto: from tangency)
    arc_tol_mm = 0.01            # chord tolerance of linearised arcs
    cutter_radius_mm = 10.0      # G-code G41/G42: the D register's radius (tool radius for a
                                 # part-contour program); without it G41/G42 are refused
    arc_centres = "incremental"  # "incremental" | "absolute": G-code I/J/K until the program
                                 # says G90.1/G91.1 (the controller's setting)

    [program]                    # the program robolobe writes (optional; robolobe.plan.program)
    min_segment_mm = 10.0        # a new spindle speed holds for at least this cutting length
    hysteresis_pct = 2.0         # S changes only where the plan's differs by more than this
    retract_mm = 5.0             # links between passes: clearance above the section
    analog_output = "1"          # KRL: $ANOUT index; RAPID: analog output signal name
    analog_rpm_full_scale = 24000  # spindle rpm at the analog output's full scale
    analog_full_scale = 1.0      # the output's full-scale value (KRL $ANOUT: 1.0)
    rapid_sync = "triggio"       # RAPID: "triggio" (TriggIO + TriggL, path-synchronous)
                                 # or "setao" (SetAO before the move)
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from robolobe._atomic import not_a_file
from robolobe._documents import parse_toml
from robolobe._frf_checks import EE_MASS_SHARE, soft_tool_mode_problem
from robolobe._toml_errors import PrintableText, check_key_typos, describe_error, key_path
from robolobe.errors import InputError, InputTypeError
from robolobe.robots.transforms import pose_from_xyz_zyx, xyz_zyx_from_pose
from robolobe.sld.io import F_RANGE_HZ, K_RANGE_N_PER_M, SAFETY_RANGE
from robolobe.stock import Stock
from robolobe.stock.engagement import MIN_CELLS_PER_DIAMETER
from robolobe.twin.effects import Effect
from robolobe.twin.effects_file import read_effects

if TYPE_CHECKING:
    from robolobe.robots.model import Robot

__all__ = [
    "FORMAT",
    "CutSpec",
    "Job",
    "MaterialSpec",
    "PlanSpec",
    "SpindleSpec",
    "StockSpec",
    "ToolMode",
    "ToolSpec",
    "job_from_dict",
    "job_to_dict",
    "job_to_toml",
    "load_job",
]

logger = logging.getLogger(__name__)

FORMAT = "robolobe-job/1"

# ------------------------------------------------------------------ schema
Num = Annotated[float, Field(allow_inf_nan=False, strict=True)]
PosNum = Annotated[float, Field(gt=0, allow_inf_nan=False, strict=True)]
NonNegNum = Annotated[float, Field(ge=0, allow_inf_nan=False, strict=True)]
Vec3 = Annotated[list[Num], Field(min_length=3, max_length=3)]


def _upto(hi: float) -> Any:
    """Field of a positive finite number at most ``hi``: the physical range of a job value.

    The upper bounds catch unit mistakes (mm given as m, rpm as rad/s, a
    stray 1e12) before they become an absurd plan; they are far above any
    machine a robot carries.
    """
    return Field(gt=0, le=hi, allow_inf_nan=False, strict=True)


#: Placement coordinates: a robot cell is metres, not kilometres (mm given as m).
PlaceVec3 = Annotated[
    list[Annotated[float, Field(ge=-50, le=50, allow_inf_nan=False, strict=True)]],
    Field(min_length=3, max_length=3),
]


class _Spec(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True)


#: Most tool rotations a "stiffest" search tries (one per degree of a full turn).
MAX_ROTATION_CANDIDATES = 360


class _RobotSpec(_Spec):
    name: Annotated[PrintableText, Field(min_length=1)]
    model: Annotated[str, Field(min_length=1)] = "twin"
    effects: Annotated[str, Field(min_length=1)] | None = None
    tool_rotation_deg: Num = 0.0
    tool_rotation: Literal["fixed", "stiffest"] = "fixed"
    tool_rotation_range_deg: Annotated[list[Num], Field(min_length=2, max_length=2)] = Field(
        default_factory=lambda: [-90.0, 90.0]
    )
    tool_rotation_step_deg: PosNum = 30.0

    @model_validator(mode="after")
    def _range(self) -> _RobotSpec:
        lo, hi = self.tool_rotation_range_deg
        if hi < lo:
            raise ValueError(
                f"tool_rotation_range_deg: expected [low, high] with low <= high, found {[lo, hi]}"
            )
        n = (hi - lo) / self.tool_rotation_step_deg
        if self.tool_rotation == "stiffest" and n > MAX_ROTATION_CANDIDATES:
            raise ValueError(
                f"tool_rotation_step_deg: expected at most {MAX_ROTATION_CANDIDATES} steps over "
                f"tool_rotation_range_deg (a step >= {(hi - lo) / MAX_ROTATION_CANDIDATES:.3g}), "
                f"found {self.tool_rotation_step_deg:g} ({n:.3g} steps)"
            )
        return self


class _PlacementSpec(_Spec):
    xyz_m: PlaceVec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    zyx_deg: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])


#: Shortest stick-out of a cutter from its holder, as a share of its diameter
#: (a face mill's body; end mills stick out several diameters).
STICKOUT_MIN_SHARE = 0.25
#: Lowest frequency [Hz] of a job's tool mode (spindle, holder, tool): a milling
#: robot's own lowest modes lie at 5-15 Hz and are the robot model's.
TOOL_MODE_F_MIN_HZ = 5.0


class _ModeSpec(_Spec):
    dir: Literal["x", "y", "xy"]
    f_hz: Annotated[
        float, Field(ge=F_RANGE_HZ[0], le=F_RANGE_HZ[1], allow_inf_nan=False, strict=True)
    ]
    zeta: Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False, strict=True)]
    k_N_per_m: Annotated[
        float,
        Field(ge=K_RANGE_N_PER_M[0], le=K_RANGE_N_PER_M[1], allow_inf_nan=False, strict=True),
    ]


class _ToolSpec(_Spec):
    diameter_mm: Annotated[float, _upto(500.0)]
    teeth: Annotated[int, Field(ge=1, le=64, strict=True)]
    helix_deg: Annotated[float, Field(ge=0, lt=90, allow_inf_nan=False, strict=True)] = 30.0
    stickout_mm: Annotated[float, _upto(1000.0)] = 50.0
    corner_radius_mm: Annotated[float, Field(ge=0, le=250, allow_inf_nan=False, strict=True)] = 0.0
    modes: list[_ModeSpec] = Field(default_factory=list)

    @model_validator(mode="after")
    def _plausible(self) -> _ToolSpec:
        least = STICKOUT_MIN_SHARE * self.diameter_mm
        if self.stickout_mm < least:
            raise ValueError(
                f"stickout_mm: expected at least {least:g} mm ({STICKOUT_MIN_SHARE:g} of the "
                f"{self.diameter_mm:g} mm diameter: the cutting length out of the holder), "
                f"found {self.stickout_mm:g}: metres for millimetres?"
            )
        for i, m in enumerate(self.modes):
            if m.f_hz < TOOL_MODE_F_MIN_HZ:
                raise ValueError(
                    f"modes[{i + 1}].f_hz: expected a spindle, holder or tool mode of at least "
                    f"{TOOL_MODE_F_MIN_HZ:g} Hz (a robot's own lowest modes; they belong to the "
                    f"robot's model), found {m.f_hz:g}: kHz for Hz?"
                )
        return self


class _MaterialSpec(_Spec):
    name: Annotated[PrintableText, Field(min_length=1)] | None = None
    Kt_N_per_mm2: PosNum | None = None
    Kr: Annotated[float, Field(ge=0, le=5, allow_inf_nan=False, strict=True)] | None = None
    Kn_N_per_mm2: NonNegNum | None = None

    @model_validator(mode="after")
    def _either(self) -> _MaterialSpec:
        if self.Kr is not None and self.Kn_N_per_mm2 is not None:
            raise ValueError("give Kr or Kn_N_per_mm2, not both")
        if self.name is None and self.Kt_N_per_mm2 is None:
            raise ValueError("expected name (built-in table) or Kt_N_per_mm2, found neither")
        if self.Kt_N_per_mm2 is not None and self.Kr is None and self.Kn_N_per_mm2 is None:
            raise ValueError("Kt_N_per_mm2 given without Kr or Kn_N_per_mm2")
        return self


class _CutSpec(_Spec):
    radial_width_mm: PosNum | None = None
    immersion: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False, strict=True)] | None = None
    milling: Literal["down", "up"] = "down"
    feed_per_tooth_mm: Annotated[float, _upto(5.0)]
    feed_per_tooth_from: Literal["program", "job"] = "program"
    feed_per_tooth_min_mm: Annotated[float, _upto(5.0)] | None = None
    feed_per_tooth_max_mm: Annotated[float, _upto(5.0)] | None = None
    # 1e4 m/min: far above any cutter (HSM of aluminium reaches ~5000): a unit slip (m/s, ft/min)
    vc_min_m_per_min: Annotated[float, _upto(1e4)] | None = None
    vc_max_m_per_min: Annotated[float, _upto(1e4)] | None = None
    max_feed_mm_per_min: Annotated[float, _upto(1e6)] | None = None
    rapid_feed_mm_per_min: Annotated[float, _upto(1e6)] = 30000.0
    programmed_rpm: Annotated[float, _upto(1e5)] | None = None
    stock_depth_mm: Annotated[float, _upto(2000.0)] | None = None

    @model_validator(mode="after")
    def _width(self) -> _CutSpec:
        if (self.radial_width_mm is None) == (self.immersion is None):
            raise ValueError("expected exactly one of radial_width_mm and immersion")
        for what, lo, hi in (
            ("vc", self.vc_min_m_per_min, self.vc_max_m_per_min),
            ("feed_per_tooth", self.feed_per_tooth_min_mm, self.feed_per_tooth_max_mm),
        ):
            unit = "m_per_min" if what == "vc" else "mm"
            if lo is not None and hi is not None and not lo < hi:
                raise ValueError(
                    f"expected {what}_min_{unit} < {what}_max_{unit}, found {lo:g} >= {hi:g}"
                )
        return self


class _SpindleSpec(_Spec):
    rpm_min: Annotated[float, _upto(1e5)]
    rpm_max: Annotated[float, _upto(1e5)]
    power_kW: Annotated[float, _upto(1000.0)]
    torque_Nm: Annotated[float, _upto(1e4)]

    @model_validator(mode="after")
    def _range(self) -> _SpindleSpec:
        if self.rpm_max <= self.rpm_min:
            raise ValueError(
                f"expected rpm_min < rpm_max, found rpm_min = {self.rpm_min:g}, "
                f"rpm_max = {self.rpm_max:g}"
            )
        return self


class _PlanSpec(_Spec):
    safety_factor: Annotated[
        float, Field(ge=SAFETY_RANGE[0], le=SAFETY_RANGE[1], allow_inf_nan=False, strict=True)
    ] = 1.3
    depth_min_mm: PosNum = 0.1
    depth_max_mm: PosNum = 10.0
    speed: Literal["scheduled", "constant"] = "scheduled"
    max_rate_rpm_per_s: PosNum | None = None
    max_rate_rpm_per_mm: PosNum | None = None
    robust: bool | None = None
    k_sigma: NonNegNum = 2.0
    spread_f_pct: Annotated[float, Field(ge=0, le=30, allow_inf_nan=False, strict=True)] = 0.5
    spread_zeta_pct: Annotated[float, Field(ge=0, le=30, allow_inf_nan=False, strict=True)] = 10.0
    spread_k_pct: Annotated[float, Field(ge=0, le=30, allow_inf_nan=False, strict=True)] = 5.0
    n_rpm: Annotated[int, Field(ge=16, le=5000, strict=True)] = 300
    dynamics_tol_pct: Annotated[float, Field(ge=0, le=10, allow_inf_nan=False, strict=True)] = 0.3

    @model_validator(mode="after")
    def _checks(self) -> _PlanSpec:
        if self.max_rate_rpm_per_s is not None and self.max_rate_rpm_per_mm is not None:
            raise ValueError("give max_rate_rpm_per_s or max_rate_rpm_per_mm, not both")
        if self.depth_max_mm < self.depth_min_mm:
            raise ValueError(
                f"expected depth_min_mm <= depth_max_mm, found {self.depth_min_mm:g} > "
                f"{self.depth_max_mm:g}"
            )
        return self


MmVec3 = Annotated[
    list[Annotated[float, Field(ge=-1e5, le=1e5, allow_inf_nan=False, strict=True)]],
    Field(min_length=3, max_length=3),
]
MmVec2 = Annotated[
    list[Annotated[float, Field(ge=-1e5, le=1e5, allow_inf_nan=False, strict=True)]],
    Field(min_length=2, max_length=2),
]


class _StockSpec(_Spec):
    box_min_mm: MmVec3 | None = None
    box_max_mm: MmVec3 | None = None
    outline_mm: Annotated[list[MmVec2], Field(min_length=3, max_length=100_000)] | None = None
    z_range_mm: MmVec2 | None = None
    mesh: Annotated[str, Field(min_length=1)] | None = None
    resolution_mm: Annotated[float, _upto(50.0)] | None = None

    @model_validator(mode="after")
    def _one_shape(self) -> _StockSpec:
        box = (self.box_min_mm is not None, self.box_max_mm is not None)
        outline = (self.outline_mm is not None, self.z_range_mm is not None)
        if any(box) and any(outline):
            raise ValueError("expected a box (box_min_mm, box_max_mm) or an outline, not both")
        if any(box) and not all(box):
            raise ValueError("expected both box_min_mm and box_max_mm, found one")
        if any(outline) and not all(outline):
            raise ValueError("expected both outline_mm and z_range_mm, found one")
        return self


class _PathSpec(_Spec):
    units: Literal["auto", "mm", "inch"] | None = None
    tool_direction: Literal["z", "x"] | None = None
    coordinates: Literal["workpiece", "machine"] | None = None
    rotary_axes: Literal["auto", "head", "table"] | None = None
    circle_axis: Literal["auto", "cw", "ccw"] | None = None
    # >= 1 um: finer chords only multiply the waypoints (1e-9 mm: millions per arc)
    arc_tol_mm: Annotated[float, Field(ge=1e-3, le=10, allow_inf_nan=False, strict=True)] | None = (
        None
    )
    cutter_radius_mm: (
        Annotated[float, Field(ge=0, le=1000, allow_inf_nan=False, strict=True)] | None
    ) = None
    arc_centres: Literal["incremental", "absolute"] | None = None


class _ProgramSpec(_Spec):
    min_segment_mm: NonNegNum = 10.0
    hysteresis_pct: Annotated[float, Field(ge=0, le=50, allow_inf_nan=False, strict=True)] = 2.0
    retract_mm: PosNum = 5.0
    analog_output: Annotated[str, Field(min_length=1)] | None = None
    analog_rpm_full_scale: PosNum | None = None
    analog_full_scale: PosNum = 1.0
    rapid_sync: Literal["triggio", "setao"] = "triggio"


class _JobSpec(_Spec):
    format: Literal["robolobe-job/1"]
    name: PrintableText = ""
    robot: _RobotSpec
    placement: _PlacementSpec = Field(default_factory=_PlacementSpec)
    tool: _ToolSpec
    material: _MaterialSpec
    cut: _CutSpec
    spindle: _SpindleSpec
    plan: _PlanSpec = Field(default_factory=_PlanSpec)
    stock: _StockSpec | None = None
    path: _PathSpec = Field(default_factory=_PathSpec)
    program: _ProgramSpec = Field(default_factory=_ProgramSpec)


_KNOWN_KEYS: dict[str, set[str]] = {
    "": set(_JobSpec.model_fields),
    "robot": set(_RobotSpec.model_fields),
    "placement": set(_PlacementSpec.model_fields),
    "tool": set(_ToolSpec.model_fields),
    "tool.modes": set(_ModeSpec.model_fields),
    "material": set(_MaterialSpec.model_fields),
    "cut": set(_CutSpec.model_fields),
    "spindle": set(_SpindleSpec.model_fields),
    "plan": set(_PlanSpec.model_fields),
    "stock": set(_StockSpec.model_fields),
    "path": set(_PathSpec.model_fields),
    "program": set(_ProgramSpec.model_fields),
}


# ------------------------------------------------------------ SI model
@dataclass(frozen=True)
class ToolMode:
    """One spindle/holder/tool mode at the tool tip, in the TCP frame.

    A job-file entry (``[[tool.modes]]``), one scalar mode of the tool, the same
    at every posture: not the robot's modal parameters
    (:class:`robolobe._modal_parameters.ModalParameters`), nor the twin's
    :class:`robolobe.twin.effects.ToolMode` (a physics effect added to the
    robot model).

    Parameters
    ----------
    direction : {"x", "y"}
        TCP axis of the driving-point FRF it adds to.
    f_hz : float
        Natural frequency [Hz].
    zeta : float
        Damping ratio (fraction).
    k_N_per_m : float
        Modal stiffness [N/m].
    """

    direction: Literal["x", "y"]
    f_hz: float
    zeta: float
    k_N_per_m: float


@dataclass(frozen=True)
class ToolSpec:
    """Cutter geometry and its modes.

    Parameters
    ----------
    diameter_m : float
        Cutter diameter [m].
    teeth : int
        Number of flutes.
    helix_rad : float
        Helix angle [rad].
    stickout_m : float
        Stick-out [m]: bounds how soft a tool mode can be (a stiffness in N/mm is
        refused, :func:`robolobe._frf_checks.tool_mode_k_floor`); the modes carry
        the dynamics.
    modes : tuple of ToolMode
        Spindle/holder/tool modes added to the robot's tool-point FRF.
    corner_radius_m : float
        Corner radius [m]: 0 a flat end mill, ``diameter_m / 2`` a ball end,
        between a bull nose.
    """

    diameter_m: float
    teeth: int
    helix_rad: float = math.radians(30.0)
    stickout_m: float = 0.05
    modes: tuple[ToolMode, ...] = ()
    corner_radius_m: float = 0.0

    def __post_init__(self) -> None:
        # the job file's check names the file and key first; this one guards the Python API
        for i, m in enumerate(self.modes):
            problem = soft_tool_mode_problem(
                m.f_hz, m.k_N_per_m, self.diameter_m, self.stickout_m, "stickout_m"
            )
            if problem is not None:
                raise InputError(f"ToolSpec.modes[{i}].k_N_per_m: {problem}")

    @property
    def shape(self) -> Literal["flat end mill", "ball-end", "bull-nose"]:
        """The cutter's end shape, from its corner radius."""
        if self.corner_radius_m <= 0.0:
            return "flat end mill"
        if self.corner_radius_m >= 0.5 * self.diameter_m * (1 - 1e-9):
            return "ball-end"
        return "bull-nose"


@dataclass(frozen=True)
class MaterialSpec:
    """Work material: a name from the sld table and/or cutting coefficients.

    Parameters
    ----------
    name : str or None
        Name in the built-in material table of :mod:`robolobe.sld`.
    Kt_N_per_m2, Kn_N_per_m2 : float or None
        Tangential and normal (radial) cutting coefficients [N/m^2]; when
        None they come from the table entry ``name``.
    """

    name: str | None = None
    Kt_N_per_m2: float | None = None
    Kn_N_per_m2: float | None = None


@dataclass(frozen=True)
class CutSpec:
    """Cutting conditions that stay fixed along the path.

    Parameters
    ----------
    radial_width_m : float
        Radial width of cut a_e [m].
    milling : {"down", "up"}
        Down (climb) or up (conventional) milling.
    feed_per_tooth_m : float
        Feed per tooth f_z [m]; the feed rate is ``f_z * teeth * rpm / 60``.
        Where the program states F and S, the plan keeps the program's chip
        load instead unless ``feed_per_tooth_from`` is ``"job"``
        (:mod:`robolobe.plan.limits`).
    max_feed_m_per_s : float or None
        Cap on the feed rate [m/s] (robot path speed), or None (the robot
        file's ``max_path_speed_mm_per_s`` then caps it).
    feed_per_tooth_from : {"program", "job"}
        Which chip load the plan keeps where the program states one.
    feed_per_tooth_range_m : (float or None, float or None)
        Chip-load range (min, max) [m] replacing the material table's; None
        where not given.
    vc_range_m_per_s : (float or None, float or None)
        Cutting-speed range (min, max) [m/s] replacing the material table's
        (file keys in m/min); None where not given.
    rapid_feed_m_per_s : float
        Speed of rapid moves [m/s], for the cycle time.
    programmed_rpm : float or None
        Spindle speed [rpm] used where the path programs none.
    stock_depth_m : float or None
        Total axial depth to remove with this path [m] (all passes), for
        per-part times (``compare``); None: not given.
    """

    radial_width_m: float
    milling: Literal["down", "up"] = "down"
    feed_per_tooth_m: float = 1e-4
    max_feed_m_per_s: float | None = None
    rapid_feed_m_per_s: float = 0.5
    programmed_rpm: float | None = None
    stock_depth_m: float | None = None
    feed_per_tooth_from: Literal["program", "job"] = "program"
    feed_per_tooth_range_m: tuple[float | None, float | None] = (None, None)
    vc_range_m_per_s: tuple[float | None, float | None] = (None, None)


@dataclass(frozen=True)
class StockSpec:
    """The job's ``[stock]``: the raw workpiece and the Z-map cell.

    Parameters
    ----------
    shape : Stock or None
        The stock (box or extruded outline, workpiece frame); None: derived
        from the program (:func:`robolobe.stock.default_stock`).
    resolution_m : float or None
        Z-map cell [m]; None: the tool diameter / 40
        (:func:`robolobe.stock.zmap_resolution`).
    """

    shape: Stock | None = None
    resolution_m: float | None = None


@dataclass(frozen=True)
class SpindleSpec:
    """Spindle limits.

    Parameters
    ----------
    rpm_min, rpm_max : float
        Speed range [rpm].
    power_W : float
        Maximum cutting power [W].
    torque_Nm : float
        Maximum torque [N m].
    """

    rpm_min: float
    rpm_max: float
    power_W: float
    torque_Nm: float


@dataclass(frozen=True)
class PlanSpec:
    """What the planner may vary and how carefully.

    Parameters
    ----------
    safety_factor : float
        Depth <= a_lim / safety_factor (>= 1).
    depth_min_m, depth_max_m : float
        Bounds on the axial depth per pass [m].
    speed : {"scheduled", "constant"}
        Speed scheduled along the path, or one speed for the whole path.
    max_rate_rpm_per_s, max_rate_rpm_per_m : float or None
        Maximum rate of change of the speed [rpm/s] or [rpm/m] (at most one).
    robust : bool or None
        Plan on the lower bound of the prediction spread; None (the job does
        not say): robust when the mode source carries a calibrated spread
        (:func:`robolobe.plan.modes.plan_bound`).
    k_sigma : float
        Width of that lower bound in standard deviations.
    assumed_spread : (float, float, float)
        Spread (std of log f, log zeta, log k) robust planning assumes where
        the mode source has none (the twin); job keys ``spread_f_pct``,
        ``spread_zeta_pct``, ``spread_k_pct`` (1 sigma, default 0.5, 10, 5 %: the
        identification accuracy a calibrated twin reaches).
    spread_set : (bool, bool, bool)
        Which of those keys the job sets: a set key overrides the source's
        own spread of that quantity.
    n_rpm : int
        Number of points of the speed grid.
    dynamics_tol : float
        Waypoints whose modes agree within this fraction in frequency (10x
        that in damping, 7x in residues, 3.3x in the frequency of modes below
        half the lowest tooth-passing frequency) share one lobe computation;
        0: each distinct waypoint gets its own.
    """

    safety_factor: float = 1.3
    depth_min_m: float = 1e-4
    depth_max_m: float = 0.01
    speed: Literal["scheduled", "constant"] = "scheduled"
    max_rate_rpm_per_s: float | None = None
    max_rate_rpm_per_m: float | None = None
    robust: bool | None = None
    k_sigma: float = 2.0
    assumed_spread: tuple[float, float, float] = (
        math.log1p(0.005),
        math.log1p(0.10),
        math.log1p(0.05),
    )
    spread_set: tuple[bool, bool, bool] = (False, False, False)
    n_rpm: int = 300
    dynamics_tol: float = 0.003


@dataclass(frozen=True, eq=False)
class Job:
    """A milling job in SI units (see the module docstring for the file).

    Parameters
    ----------
    robot : str
        ``"A"``, ``"B"``, ``"C"`` or the (absolute) path of a robot file.
    model : str
        ``"twin"`` (default: the robot file's twin; for a calibrated robot
        file, e.g. from ``robolobe transfer --method twin-calibration``, the
        calibrated twin), ``"builtin"`` (the shipped network of A, B, C, which
        misses its twin's modes by 3-15 % in frequency, README) or the
        (absolute) path of a tl model file.
    effects : tuple of Effect
        Physics effects added to the twin (job key ``robot.effects``: an
        ``effects.toml`` file, e.g. from ``robolobe diagnose --updated-model``;
        only with ``model = "twin"``); ``effects_file`` is its path.
    placement : ndarray, shape (4, 4)
        Pose of the workpiece (path) frame in the robot base frame.
    tool, material, cut, spindle, plan : see their classes.
    stock : StockSpec or None
        The job's ``[stock]``; None: no section (the radial engagement of
        ``[cut]`` stands for the whole path).
    tool_rotation_rad : float
        Rotation [rad] of the TCP x axis about the tool axis (added to the
        orientation the path gives, or to the default reference direction).
    tool_rotation : {"fixed", "stiffest"}
        Keep ``tool_rotation_rad`` or search ``tool_rotation_range_rad`` in
        steps of ``tool_rotation_step_rad`` for the stiffest choice.
    name, source : str
        Free text; the file the job came from.
    path_options : dict
        Toolpath reader options (job section ``[path]``; see
        :data:`robolobe.plan.paths.READER_OPTIONS`); only those set.
    program_options : dict
        Program writer settings (job section ``[program]``, file units; see
        :func:`robolobe.plan.program.write_program`); only those set.
    """

    robot: str
    tool: ToolSpec
    material: MaterialSpec
    cut: CutSpec
    spindle: SpindleSpec
    plan: PlanSpec = field(default_factory=PlanSpec)
    stock: StockSpec | None = None
    model: str = "twin"
    effects: tuple[Effect, ...] = ()
    effects_file: str | None = None
    placement: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool_rotation_rad: float = 0.0
    tool_rotation: Literal["fixed", "stiffest"] = "fixed"
    tool_rotation_range_rad: tuple[float, float] = (-math.pi / 2, math.pi / 2)
    tool_rotation_step_rad: float = math.radians(30.0)
    name: PrintableText = ""
    source: str = "<code>"
    path_options: dict[str, Any] = field(default_factory=dict)
    program_options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        p = np.array(self.placement, dtype=np.float64)
        if p.shape != (4, 4) or not np.all(np.isfinite(p)):
            raise ValueError(f"placement: expected a finite 4x4 pose, found shape {p.shape}")
        p.setflags(write=False)
        object.__setattr__(self, "placement", p)

    @property
    def radial_immersion(self) -> float:
        """a_e / D (dimensionless)."""
        return self.cut.radial_width_m / self.tool.diameter_m

    def replace(self, **changes: Any) -> Job:
        """Copy with fields replaced (:func:`dataclasses.replace`)."""
        import dataclasses

        return dataclasses.replace(self, **changes)


# ------------------------------------------------------------ key paths


def _check_typos(raw: dict[str, Any], where: str) -> None:
    tables: list[tuple[Any, set[str], str]] = [(raw, _KNOWN_KEYS[""], "")]
    for sec in (
        "robot",
        "placement",
        "tool",
        "material",
        "cut",
        "spindle",
        "plan",
        "stock",
        "path",
        "program",
    ):
        tables.append((raw.get(sec), _KNOWN_KEYS[sec], f"{sec}."))
    tool = raw.get("tool")
    if isinstance(tool, dict) and isinstance(tool.get("modes"), list):
        for i, m in enumerate(tool["modes"]):
            tables.append((m, _KNOWN_KEYS["tool.modes"], f"tool.modes[{i + 1}]."))
    check_key_typos(tables, where)


# ------------------------------------------------------------ tool modes
def _check_tool_modes(t: _ToolSpec, where: str) -> None:
    """Refuse a tool mode softer than a tool of its size can be (a stiffness in N/mm).

    The bound (:func:`robolobe._frf_checks.tool_mode_k_floor`) takes the
    tool's diameter and stick-out; a stick-out left at its default is said,
    as the other way out of the refusal.
    """
    default = "stickout_mm" not in t.model_fields_set
    for i, m in enumerate(t.modes):
        problem = soft_tool_mode_problem(
            m.f_hz, m.k_N_per_m, t.diameter_mm * 1e-3, t.stickout_mm * 1e-3,
            "tool.stickout_mm", default=default,
        )  # fmt: skip
        if problem is not None:
            raise InputError(f"tool.modes[{i + 1}].k_N_per_m: {problem}", source=where)


def check_tool_modes_on(tool: ToolSpec, robot: Robot, source: str) -> None:
    """Refuse a tool mode too soft for the tool on this robot's spindle (a stiffness in N/mm).

    The job's own check knows the tool only; with the robot, a mode at least as
    heavy as its spindle at the tip (:meth:`Robot.tcp_effective_mass_kg` in the
    tool's x/y plane times :data:`robolobe._frf_checks.EE_MASS_SHARE`) must be
    as stiff as that mass at the mode's frequency
    (:func:`robolobe._frf_checks.tool_mode_k_floor`).

    Raises
    ------
    InputError
        Naming ``source``, the mode and the robot.
    """
    m = robot.tcp_effective_mass_kg()[:2]
    if not tool.modes or not np.all(m > 0):
        return
    carrier = EE_MASS_SHARE * float(m.min())
    for i, mode in enumerate(tool.modes):
        problem = soft_tool_mode_problem(
            mode.f_hz, mode.k_N_per_m, tool.diameter_m, tool.stickout_m, "tool.stickout_mm",
            carrier_kg=carrier,
        )  # fmt: skip
        if problem is not None:
            raise InputError(
                f"tool.modes[{i + 1}] ({mode.direction}, {mode.f_hz:g} Hz).k_N_per_m on robot "
                f"{robot.name!r}: {problem}",
                source=source,
            )


# ---------------------------------------------------------------- build
def _resolve_file(value: str, base_dir: Path | None) -> str:
    p = Path(value)
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    return str(p)


def job_from_dict(d: dict[str, Any], source: str = "<dict>", base_dir: Path | None = None) -> Job:
    """Validate a parsed job file and build a :class:`Job`.

    Parameters
    ----------
    d : dict
        Parsed TOML.
    source : str
        Name used in error messages (the file name).
    base_dir : Path, optional
        Directory that relative file names (robot, model) are relative to.

    Raises
    ------
    InputError
        Naming ``source`` and the key.
    """
    where = Path(source).name if source not in ("<dict>", "<code>") else source
    _check_typos(d, where)
    try:
        spec = _JobSpec.model_validate(d)
    except ValidationError as exc:
        err = exc.errors()[0]
        key = key_path(tuple(err["loc"]))
        raise InputError(f"{key}: {describe_error(err)}", source=where) from None

    r = spec.robot
    robot = r.name
    if robot.upper() in ("A", "B", "C") and not (base_dir and (base_dir / robot).exists()):
        robot = robot.upper()
    else:
        robot = _resolve_file(robot, base_dir)
        if not Path(robot).is_file():
            raise InputError(
                f"robot.name: expected 'A', 'B', 'C' or a robot file, found {r.name!r} "
                f"({not_a_file(robot)})",
                source=where,
            )
    model = r.model
    if model not in ("builtin", "twin"):
        model = _resolve_file(model, base_dir)
        if not Path(model).exists():
            raise InputError(
                f"robot.model: expected 'builtin', 'twin' or a model file, found {r.model!r} "
                "(no such file)",
                source=where,
            )

    effects: tuple[Effect, ...] = ()
    effects_file: str | None = None
    if r.effects is not None:
        if model != "twin":
            raise InputError(
                f"robot.effects: physics effects act on the twin; expected robot.model = 'twin', "
                f"found {r.model!r}",
                source=where,
            )
        effects_file = _resolve_file(r.effects, base_dir)
        effects = read_effects(effects_file)

    t = spec.tool
    _check_tool_modes(t, where)
    modes: list[ToolMode] = []
    for m in t.modes:
        dirs: tuple[Literal["x", "y"], ...] = ("x", "y") if m.dir == "xy" else (m.dir,)
        modes.extend(ToolMode(di, m.f_hz, m.zeta, m.k_N_per_m) for di in dirs)
    tool = ToolSpec(
        diameter_m=t.diameter_mm * 1e-3,
        teeth=t.teeth,
        helix_rad=math.radians(t.helix_deg),
        stickout_m=t.stickout_mm * 1e-3,
        modes=tuple(modes),
        corner_radius_m=t.corner_radius_mm * 1e-3,
    )
    if t.corner_radius_mm > 0.5 * t.diameter_mm * (1 + 1e-9):
        raise InputError(
            f"tool.corner_radius_mm: expected at most half the diameter "
            f"({0.5 * t.diameter_mm:g}), found {t.corner_radius_mm:g}",
            source=where,
        )
    stock = _stock(spec.stock, tool, where)

    mt = spec.material
    kt = mt.Kt_N_per_mm2 * 1e6 if mt.Kt_N_per_mm2 is not None else None
    kn: float | None = None
    if kt is not None:
        kn = mt.Kn_N_per_mm2 * 1e6 if mt.Kn_N_per_mm2 is not None else kt * float(mt.Kr or 0.0)
    material = MaterialSpec(name=mt.name, Kt_N_per_m2=kt, Kn_N_per_m2=kn)

    c = spec.cut
    width = c.radial_width_mm * 1e-3 if c.radial_width_mm is not None else None
    if width is None:
        width = float(c.immersion or 0.0) * tool.diameter_m
    if width > tool.diameter_m * (1 + 1e-9):
        raise InputError(
            f"cut.radial_width_mm: expected at most the tool diameter {t.diameter_mm:g}, "
            f"found {c.radial_width_mm:g}",
            source=where,
        )
    cut = CutSpec(
        radial_width_m=min(width, tool.diameter_m),
        milling=c.milling,
        feed_per_tooth_m=c.feed_per_tooth_mm * 1e-3,
        max_feed_m_per_s=c.max_feed_mm_per_min * 1e-3 / 60 if c.max_feed_mm_per_min else None,
        rapid_feed_m_per_s=c.rapid_feed_mm_per_min * 1e-3 / 60,
        programmed_rpm=c.programmed_rpm,
        stock_depth_m=c.stock_depth_mm * 1e-3 if c.stock_depth_mm else None,
        feed_per_tooth_from=c.feed_per_tooth_from,
        feed_per_tooth_range_m=(
            _scaled(c.feed_per_tooth_min_mm, 1e-3),
            _scaled(c.feed_per_tooth_max_mm, 1e-3),
        ),
        vc_range_m_per_s=(_scaled(c.vc_min_m_per_min, 1 / 60), _scaled(c.vc_max_m_per_min, 1 / 60)),
    )
    s = spec.spindle
    spindle = SpindleSpec(s.rpm_min, s.rpm_max, s.power_kW * 1e3, s.torque_Nm)
    p = spec.plan
    plan = PlanSpec(
        safety_factor=p.safety_factor,
        depth_min_m=p.depth_min_mm * 1e-3,
        depth_max_m=p.depth_max_mm * 1e-3,
        speed=p.speed,
        max_rate_rpm_per_s=p.max_rate_rpm_per_s,
        max_rate_rpm_per_m=p.max_rate_rpm_per_mm * 1e3 if p.max_rate_rpm_per_mm else None,
        robust=p.robust,
        k_sigma=p.k_sigma,
        assumed_spread=(
            math.log1p(p.spread_f_pct / 100.0),
            math.log1p(p.spread_zeta_pct / 100.0),
            math.log1p(p.spread_k_pct / 100.0),
        ),
        spread_set=(
            "spread_f_pct" in p.model_fields_set,
            "spread_zeta_pct" in p.model_fields_set,
            "spread_k_pct" in p.model_fields_set,
        ),
        n_rpm=p.n_rpm,
        dynamics_tol=p.dynamics_tol_pct / 100.0,
    )
    pl = spec.placement
    placement = pose_from_xyz_zyx(pl.xyz_m, np.radians(pl.zyx_deg))
    lo, hi = r.tool_rotation_range_deg
    return Job(
        robot=robot,
        model=model,
        effects=effects,
        effects_file=effects_file,
        placement=placement,
        tool=tool,
        material=material,
        cut=cut,
        spindle=spindle,
        plan=plan,
        stock=stock,
        tool_rotation_rad=math.radians(r.tool_rotation_deg),
        tool_rotation=r.tool_rotation,
        tool_rotation_range_rad=(math.radians(lo), math.radians(hi)),
        tool_rotation_step_rad=math.radians(r.tool_rotation_step_deg),
        name=spec.name,
        source=source,
        path_options={
            k: v
            for k, v in spec.path.model_dump().items()
            if v is not None and k in _KNOWN_KEYS["path"]
        },
        program_options={
            k: getattr(spec.program, k)
            for k in spec.program.model_fields_set
            if k in _KNOWN_KEYS["program"]
        },
    )


def _scaled(v: float | None, factor: float) -> float | None:
    return None if v is None else v * factor


def _stock(s: _StockSpec | None, tool: ToolSpec, where: str) -> StockSpec | None:
    """The ``[stock]`` section in SI units, checked against the cutter."""
    if s is None:
        return None
    if s.mesh is not None:
        raise InputError(
            f"stock.mesh: expected box_min_mm/box_max_mm or outline_mm with z_range_mm, found "
            f"a mesh ({s.mesh!r}): mesh stocks (STL) are not supported (no mesh library is a "
            "dependency; the Z-map needs an outline and a top)",
            source=where,
        )
    if tool.shape != "flat end mill":
        raise InputError(
            f"tool.corner_radius_mm: the [stock] engagement (a Z-map) models flat end mills "
            f"only; expected 0 with [stock], found {tool.corner_radius_m * 1e3:g} (a "
            f"{tool.shape} cutter): remove [stock] to plan at cut.radial_width_mm",
            source=where,
        )
    res = s.resolution_mm * 1e-3 if s.resolution_mm is not None else None
    coarsest = tool.diameter_m / MIN_CELLS_PER_DIAMETER
    if res is not None and res > coarsest * (1 + 1e-9):
        raise InputError(
            f"stock.resolution_mm: expected at most the tool diameter / "
            f"{MIN_CELLS_PER_DIAMETER} = {coarsest * 1e3:.4g} mm for the "
            f"{tool.diameter_m * 1e3:g} mm cutter, found {s.resolution_mm:g}",
            source=where,
        )
    shape: Stock | None = None
    key = "stock"
    try:
        if s.box_min_mm is not None and s.box_max_mm is not None:
            key = "stock.box_min_mm"
            lo = tuple(v * 1e-3 for v in s.box_min_mm)
            hi = tuple(v * 1e-3 for v in s.box_max_mm)
            shape = Stock.box((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2]))
        elif s.outline_mm is not None and s.z_range_mm is not None:
            key = "stock.outline_mm"
            pts = np.array(s.outline_mm, dtype=np.float64) * 1e-3
            zb, zt = s.z_range_mm
            if not zb < zt:
                key = "stock.z_range_mm"
                raise ValueError(f"expected [bottom, top] with bottom < top, found {[zb, zt]}")
            shape = Stock(pts, zb * 1e-3, zt * 1e-3, kind="outline")
    except ValueError as exc:
        raise InputError(f"{key}: {exc}", source=where) from None
    return StockSpec(shape=shape, resolution_m=res)


def load_job(path: str | os.PathLike[str] | Job) -> Job:
    """Read and validate a job file.

    Parameters
    ----------
    path : path-like or Job
        TOML file with ``format = "robolobe-job/1"`` (a :class:`Job` is
        returned as it is).

    Returns
    -------
    Job

    Raises
    ------
    InputError
        Unreadable file, TOML syntax error (with its line) or invalid content
        (naming the key).
    """
    if isinstance(path, Job):
        return path
    if not isinstance(path, str | os.PathLike):
        raise InputTypeError("job", "a job file's path or a Job", path)
    p = Path(path)
    where = p.name
    if not p.is_file():
        raise InputError(f"expected a job file (TOML), found {not_a_file(p)}", source=str(p))
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the file: {exc}", source=where) from None
    raw = parse_toml(text, where)
    return job_from_dict(raw, source=str(p), base_dir=p.resolve().parent)


# --------------------------------------------------------------- writing
def _clean(x: float) -> float | int:
    v = float(x)
    r = round(v, 10)
    return int(r) if r.is_integer() and abs(r) < 1e15 else r


def job_to_dict(job: Job) -> dict[str, Any]:
    """The job as a TOML-ready dict in file units (inverse of :func:`job_from_dict`)."""
    xyz, zyx = xyz_zyx_from_pose(job.placement)
    modes: list[dict[str, Any]] = [
        {"dir": m.direction, "f_hz": m.f_hz, "zeta": m.zeta, "k_N_per_m": m.k_N_per_m}
        for m in job.tool.modes
    ]
    mat: dict[str, Any] = {}
    if job.material.name is not None:
        mat["name"] = job.material.name
    if job.material.Kt_N_per_m2 is not None:
        mat["Kt_N_per_mm2"] = _clean(job.material.Kt_N_per_m2 * 1e-6)
        mat["Kn_N_per_mm2"] = _clean((job.material.Kn_N_per_m2 or 0.0) * 1e-6)
    cut: dict[str, Any] = {
        "radial_width_mm": _clean(job.cut.radial_width_m * 1e3),
        "milling": job.cut.milling,
        "feed_per_tooth_mm": _clean(job.cut.feed_per_tooth_m * 1e3),
        "rapid_feed_mm_per_min": _clean(job.cut.rapid_feed_m_per_s * 6e4),
    }
    if job.cut.max_feed_m_per_s is not None:
        cut["max_feed_mm_per_min"] = _clean(job.cut.max_feed_m_per_s * 6e4)
    if job.cut.programmed_rpm is not None:
        cut["programmed_rpm"] = _clean(job.cut.programmed_rpm)
    if job.cut.stock_depth_m is not None:
        cut["stock_depth_mm"] = _clean(job.cut.stock_depth_m * 1e3)
    if job.cut.feed_per_tooth_from != "program":
        cut["feed_per_tooth_from"] = job.cut.feed_per_tooth_from
    for key, val, f in (
        ("feed_per_tooth_min_mm", job.cut.feed_per_tooth_range_m[0], 1e3),
        ("feed_per_tooth_max_mm", job.cut.feed_per_tooth_range_m[1], 1e3),
        ("vc_min_m_per_min", job.cut.vc_range_m_per_s[0], 60.0),
        ("vc_max_m_per_min", job.cut.vc_range_m_per_s[1], 60.0),
    ):
        if val is not None:
            cut[key] = _clean(val * f)
    pl = job.plan
    plan: dict[str, Any] = {
        "safety_factor": _clean(pl.safety_factor),
        "depth_min_mm": _clean(pl.depth_min_m * 1e3),
        "depth_max_mm": _clean(pl.depth_max_m * 1e3),
        "speed": pl.speed,
        "k_sigma": _clean(pl.k_sigma),
        "n_rpm": pl.n_rpm,
        "dynamics_tol_pct": _clean(pl.dynamics_tol * 100.0),
    }
    if pl.robust is not None:
        plan["robust"] = pl.robust
    for key, val, given in zip(
        ("spread_f_pct", "spread_zeta_pct", "spread_k_pct"),
        pl.assumed_spread,
        pl.spread_set,
        strict=True,
    ):
        if given:
            plan[key] = _clean(math.expm1(val) * 100.0)
    if pl.max_rate_rpm_per_s is not None:
        plan["max_rate_rpm_per_s"] = _clean(pl.max_rate_rpm_per_s)
    if pl.max_rate_rpm_per_m is not None:
        plan["max_rate_rpm_per_mm"] = _clean(pl.max_rate_rpm_per_m * 1e-3)
    robot: dict[str, Any] = {"name": job.robot, "model": job.model}
    if job.effects_file is not None:
        robot["effects"] = job.effects_file
    return {
        "format": FORMAT,
        "name": job.name,
        "robot": {
            **robot,
            "tool_rotation_deg": _clean(math.degrees(job.tool_rotation_rad)),
            "tool_rotation": job.tool_rotation,
            "tool_rotation_range_deg": [
                _clean(math.degrees(v)) for v in job.tool_rotation_range_rad
            ],
            "tool_rotation_step_deg": _clean(math.degrees(job.tool_rotation_step_rad)),
        },
        "placement": {
            "xyz_m": [_clean(v) for v in xyz],
            "zyx_deg": [_clean(v) for v in np.degrees(zyx)],
        },
        "tool": {
            "diameter_mm": _clean(job.tool.diameter_m * 1e3),
            "teeth": job.tool.teeth,
            "helix_deg": _clean(math.degrees(job.tool.helix_rad)),
            "stickout_mm": _clean(job.tool.stickout_m * 1e3),
            "corner_radius_mm": _clean(job.tool.corner_radius_m * 1e3),
            "modes": modes,
        },
        "material": mat,
        "cut": cut,
        "spindle": {
            "rpm_min": _clean(job.spindle.rpm_min),
            "rpm_max": _clean(job.spindle.rpm_max),
            "power_kW": _clean(job.spindle.power_W * 1e-3),
            "torque_Nm": _clean(job.spindle.torque_Nm),
        },
        "plan": plan,
        **({"stock": _stock_to_dict(job.stock)} if job.stock is not None else {}),
        **({"path": dict(job.path_options)} if job.path_options else {}),
        **({"program": dict(job.program_options)} if job.program_options else {}),
    }


def _stock_to_dict(spec: StockSpec) -> dict[str, Any]:
    out: dict[str, Any] = {}
    s = spec.shape
    if s is not None and s.kind == "box":
        x0, y0, x1, y1 = s.bounds()
        out["box_min_mm"] = [_clean(x0 * 1e3), _clean(y0 * 1e3), _clean(s.z_bottom * 1e3)]
        out["box_max_mm"] = [_clean(x1 * 1e3), _clean(y1 * 1e3), _clean(s.z_top * 1e3)]
    elif s is not None:
        out["outline_mm"] = [[_clean(x * 1e3), _clean(y * 1e3)] for x, y in s.outline]
        out["z_range_mm"] = [_clean(s.z_bottom * 1e3), _clean(s.z_top * 1e3)]
    if spec.resolution_m is not None:
        out["resolution_mm"] = _clean(spec.resolution_m * 1e3)
    return out


def job_to_toml(job: Job) -> str:
    """The job as TOML text (reads back with :func:`load_job` to an equal job)."""
    d = job_to_dict(job)
    # tomli-w writes ints for whole floats where we cleaned them; that is fine for
    # strict float fields (pydantic accepts ints for floats).
    return tomli_w.dumps(d)
