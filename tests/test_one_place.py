"""Each concept is defined once (issue 15): the library's calls that mark a concept's home.

Checked on the syntax tree of every module under ``src/robolobe`` (calls
inside functions included, however the function was imported):

* **state-space poles** of ``M x'' + C x' + K x = 0``: the only
  non-symmetric eigen-solve (``eig``/``eigvals`` of numpy or scipy) is in
  ``twin/_poles.py``; a few other eigenproblems are different concepts and
  listed with the reason;
* **mode matching**: the only linear sum assignment is in ``_matching.py``;
* **the worker pool**: joblib's ``Parallel`` is called in ``_workers.py`` only
  (plus the batch planner's unordered stream of whole plans).

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

#: joblib pools: module -> why it is not :func:`robolobe._workers.map_chunks`.
POOL_ELSEWHERE: dict[str, str] = {
    "_workers.py": "the home: map_chunks (ordered, chunked, one BLAS thread per worker)",
    "plan/batch.py": "whole plans streamed unordered as each finishes, beside a Dask cluster",
}

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
