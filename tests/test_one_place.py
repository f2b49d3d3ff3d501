"""Each concept is defined once (issue 15): the library's calls that mark a concept's home.

Checked on the syntax tree of every module under ``src/robolobe`` (calls
inside functions included, however the function was imported):

* **state-space poles** of ``M x'' + C x' + K x = 0``: the only
  non-symmetric eigen-solve (``eig``/``eigvals`` of numpy or scipy) is in
  ``twin/_poles.py``; a few other eigenproblems are different concepts and
  listed with the reason;
* **mode matching**: the only linear sum assignment is in ``_matching.py``;
* **modal parameters**: the only public class declaring ``f_hz``, ``zeta``
  and ``k_N_per_m`` fields is :class:`robolobe._modal_parameters.ModalParameters`;
  the few others are different concepts, listed with the reason;
* **the worker pool**: joblib's ``Parallel`` is called in ``_workers.py`` only
  (plus the batch planner's unordered stream of whole plans);
* **mass matrices from body Jacobians**: products (``einsum``, ``@``) over a
  body's Jacobians ``jv``/``jw`` are in the twin's assembly (``twin/dynamics.py``)
  and the parametrised-twin core (``twin/params.py``, moved centres of mass,
  scaled inertias, their derivatives and gravity torques) only.

A new call elsewhere fails here: call the home instead, or add it below
with the reason it is a different concept.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "robolobe"

#: Non-symmetric eigen-solves: module -> why it is not the twin's poles.
EIG_ELSEWHERE: dict[str, str] = {
    "twin/_poles.py": "the home: the state-space poles of the twin's (M, C, K)",
    "modal/plscf.py": "roots of an identified right-matrix-fraction denominator "
    "(companion matrix of the fitted polynomial), not a mechanical model's poles",
    "sld/sdm.py": "Floquet multipliers of the milling process' monodromy matrix",
}

#: Linear sum assignments: module -> why it is not :func:`robolobe._matching.match_modes`.
ASSIGNMENT_ELSEWHERE: dict[str, str] = {
    "_matching.py": "the home: match_modes",
}

#: Public classes with f_hz + zeta + k_N_per_m fields: "module:Class" -> why it is not
#: a second copy of :class:`robolobe._modal_parameters.ModalParameters`.
MODAL_FIELDS_ELSEWHERE: dict[str, str] = {
    "_modal_parameters.py:ModalParameters": "the home",
    "twin/modes.py:Modes": "the twin's coupled modes in pole-residue and mode-shape form "
    "(one frequency per mode, poles, residues, shapes); Modes.parameters() gives the type",
    "modal/measurement.py:MeasurementModal": "modes of one measurement of arbitrary FRFs: a "
    "signed stiffness per FRF channel, not per TCP direction",
    "plan/job.py:ToolMode": "one spindle/tool mode of a job file (a scalar configuration "
    "entry, not a posture batch)",
    "sld/io.py:ModeRow": "one row of an sld modes file with its line number, for messages "
    "that name the line (a scalar file entry, not a posture batch)",
    "twin/calibration.py:ModeSummary": "statistics of a seed-table mode over postures "
    "(low, median, high of each parameter), not modal parameters",
    "twin/calibration.py:TableComparison": "a comparison record: the twin's modes matched "
    "to a seed table's, in the table's mode order (not the twin's lowest modes), beside "
    "their errors against it",
}

MODAL_FIELDS = {"f_hz", "zeta", "k_N_per_m"}

#: joblib pools: module -> why it is not :func:`robolobe._workers.map_chunks`.
POOL_ELSEWHERE: dict[str, str] = {
    "_workers.py": "the home: map_chunks (ordered, chunked, one BLAS thread per worker)",
    "plan/batch.py": "whole plans streamed unordered as each finishes, beside a Dask cluster",
}

#: Products over body Jacobians: module -> why it is not
#: :class:`robolobe.twin.params.BodyMassModel`.
BODY_JACOBIAN_ELSEWHERE: dict[str, str] = {
    "twin/params.py": "the home: BodyMassModel, the parametrised-twin core",
    "twin/dynamics.py": "the twin's own assembly of a robot's bodies (BodySet.mass_matrix, "
    "gravity_torques), which the core's test checks it against",
}

BODY_JACOBIANS = {"jv", "jw"}

EIG_NAMES = {"eig", "eigvals"}
ASSIGNMENT_NAMES = {"linear_sum_assignment"}
POOL_NAMES = {"Parallel"}


def _called_names(path: Path) -> set[str]:
    """Names of the functions a module calls (``f(...)``, ``a.b.f(...)``) or imports."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Name):
                out.add(f.id)
            elif isinstance(f, ast.Attribute):
                out.add(f.attr)
        elif isinstance(node, ast.ImportFrom):
            out |= {a.name for a in node.names}
    return out


def _uses_body_jacobians(path: Path) -> bool:
    """Whether a module multiplies body Jacobians: ``einsum`` or ``@`` with an operand that
    names ``jv``/``jw`` (``b.jv``, ``self._jw[:, i]``...; ``tcp_jv`` is the TCP's, not a body's)."""

    def names(node: ast.AST) -> set[str]:
        out = set()
        for n in ast.walk(node):
            if isinstance(n, ast.Name):
                out.add(n.id.lstrip("_"))
            elif isinstance(n, ast.Attribute):
                out.add(n.attr.lstrip("_"))
        return out

    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            f = node.func
            name = (
                f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            )
            if name == "einsum" and any(names(a) & BODY_JACOBIANS for a in node.args):
                return True
        elif (
            isinstance(node, ast.BinOp)
            and isinstance(node.op, ast.MatMult)
            and (names(node.left) | names(node.right)) & BODY_JACOBIANS
        ):
            return True
    return False


def _modules_calling(names: set[str]) -> set[str]:
    return {
        p.relative_to(SRC).as_posix() for p in sorted(SRC.rglob("*.py")) if _called_names(p) & names
    }


@pytest.mark.slow
def test_state_space_poles_are_solved_in_one_place() -> None:
    found = _modules_calling(EIG_NAMES)
    assert found <= set(EIG_ELSEWHERE), (
        f"non-symmetric eigen-solves outside robolobe.twin._poles: "
        f"{sorted(found - set(EIG_ELSEWHERE))}; call robolobe.twin._poles "
        "(state_space_eig, modal_poles, pole_vectors) or list the module with its reason"
    )
    assert "twin/_poles.py" in found


@pytest.mark.slow
def test_mode_lists_are_matched_in_one_place() -> None:
    found = _modules_calling(ASSIGNMENT_NAMES)
    assert found <= set(ASSIGNMENT_ELSEWHERE), (
        f"linear sum assignments outside robolobe._matching: "
        f"{sorted(found - set(ASSIGNMENT_ELSEWHERE))}; call robolobe._matching.match_modes"
    )
    assert "_matching.py" in found


def _classes_with_fields(path: Path, fields: set[str]) -> set[str]:
    """Public classes of a module (nested too) whose body annotates all of ``fields``."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            names = {
                st.target.id
                for st in node.body
                if isinstance(st, ast.AnnAssign) and isinstance(st.target, ast.Name)
            }
            if fields <= names:
                out.add(node.name)
    return out


@pytest.mark.slow
def test_modal_parameters_are_declared_in_one_place() -> None:
    found = {
        f"{p.relative_to(SRC).as_posix()}:{c}"
        for p in sorted(SRC.rglob("*.py"))
        for c in _classes_with_fields(p, MODAL_FIELDS)
    }
    assert found <= set(MODAL_FIELDS_ELSEWHERE), (
        f"classes declaring f_hz, zeta and k_N_per_m outside robolobe._modal_parameters: "
        f"{sorted(found - set(MODAL_FIELDS_ELSEWHERE))}; hold or return a ModalParameters "
        "instead, or list the class with the reason it is a different concept"
    )
    gone = set(MODAL_FIELDS_ELSEWHERE) - found
    assert not gone, f"no longer declare the fields: remove {sorted(gone)} from the list"


def test_the_field_check_sees_dataclasses_and_plain_classes(tmp_path: Path) -> None:
    mod = tmp_path / "m.py"
    mod.write_text(
        "from dataclasses import dataclass\n"
        "@dataclass\n"
        "class Bundle:\n"
        "    f_hz: float\n"
        "    zeta: float\n"
        "    k_N_per_m: float\n"
        "class _Private:\n"
        "    f_hz: float\n    zeta: float\n    k_N_per_m: float\n"
        "class Partial:\n"
        "    f_hz: float\n    zeta: float\n"
        "    def k_N_per_m(self) -> float: ...\n",
        encoding="utf-8",
    )
    assert _classes_with_fields(mod, MODAL_FIELDS) == {"Bundle"}


@pytest.mark.slow
def test_work_is_fanned_out_over_workers_in_one_place() -> None:
    found = _modules_calling(POOL_NAMES)
    assert found <= set(POOL_ELSEWHERE), (
        f"joblib pools outside robolobe._workers: {sorted(found - set(POOL_ELSEWHERE))}; "
        "call robolobe._workers.map_chunks"
    )
    assert "_workers.py" in found


def test_the_check_sees_calls_inside_functions(tmp_path: Path) -> None:
    mod = tmp_path / "m.py"
    mod.write_text(
        "def f(a):\n"
        "    import numpy as np\n"
        "    from scipy import optimize\n"
        "    return np.linalg.eigvals(a), optimize.linear_sum_assignment(a)\n",
        encoding="utf-8",
    )
    names = _called_names(mod)
    assert "eigvals" in names
    assert "linear_sum_assignment" in names


@pytest.mark.slow
def test_mass_matrices_are_assembled_from_body_jacobians_in_one_place() -> None:
    found = {
        p.relative_to(SRC).as_posix() for p in sorted(SRC.rglob("*.py")) if _uses_body_jacobians(p)
    }
    assert found <= set(BODY_JACOBIAN_ELSEWHERE), (
        f"products over body Jacobians (jv, jw) outside robolobe.twin.params: "
        f"{sorted(found - set(BODY_JACOBIAN_ELSEWHERE))}; get the mass matrix, its derivatives "
        "and gravity torques from robolobe.twin.params.BodyMassModel, or list the module with "
        "the reason it is a different concept"
    )
    assert "twin/params.py" in found


def test_the_body_jacobian_check_sees_einsum_and_matmul(tmp_path: Path) -> None:
    seen = {
        "a.py": "import numpy as np\ndef f(b):\n    return np.einsum('bki,bkj->ij', b.jv, b.jv)\n",
        "b.py": "def f(self, g, p):\n    return g.T @ self._jw[p]\n",
        "c.py": "def f(jv, w):\n    return (jv.T @ w).sum()\n",
    }
    unseen = {
        "d.py": "def f(s):\n    return s.rot @ s.tcp_jv\n",
        "e.py": "import numpy as np\ndef f(a, jv):\n    return np.einsum('ij,jk->ik', a, a), jv\n",
    }
    for name, text in {**seen, **unseen}.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
        assert _uses_body_jacobians(tmp_path / name) == (name in seen), name
