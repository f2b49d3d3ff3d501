"""Every public function of ``robolobe.__all__`` given values of the wrong type (hypothesis).

The class: a number, None, bytes, a list, a dict, a string of robots, NaN, an
object or a path to a folder or a device where the function takes something
else. Each call either works, or ends in a :class:`robolobe.errors.RobolobeError`
of one line, or in a ``TypeError`` that says which type was expected (Python's
own ``expected str, bytes or os.PathLike object``); never an
``AttributeError``, ``KeyError``, ``IndexError``, a bare ``ValueError`` or a
``TypeError`` from deep inside ("'NoneType' object is not iterable").
"""

from __future__ import annotations

import inspect
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import robolobe
from robolobe.errors import RobolobeError

FUZZ = settings(
    max_examples=12,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

#: Words of a TypeError that says what it expected.
SAYS_TYPE = re.compile(r"expected|must be|should be")


def _required(obj: Any) -> tuple[int, list[str]]:
    """Required positional parameters (their number) and keyword-only ones (their names)."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return 1, []
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    need = [p for p in sig.parameters.values() if p.default is p.empty]
    return (
        sum(p.kind in kinds for p in need),
        [p.name for p in need if p.kind is inspect.Parameter.KEYWORD_ONLY],
    )


def _public_callables() -> list[str]:
    out = []
    for name in robolobe.__all__:
        obj = getattr(robolobe, name)
        if inspect.isclass(obj) and issubclass(obj, BaseException):
            continue
        if callable(obj) and _required(obj)[0]:  # estimators take their settings by keyword
            out.append(name)
    return out


wrong = st.one_of(
    st.sampled_from([None, 3, -1, 3.5, math.nan, math.inf, b"x", [], {}, ["A"], (), "A,B"]),
    st.sampled_from([object(), np.zeros(3), np.array(["x"]), {"a": [1]}, [[1, 2], [3]]]),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=6),
)


def _problem(obj: Any, args: list[Any], kwargs: dict[str, Any]) -> str | None:
    """What is wrong with how ``obj(*args, **kwargs)`` ends, or None."""
    try:
        obj(*args, **kwargs)
    except RobolobeError as exc:
        return None if "\n" not in str(exc).strip() else f"a message of several lines: {exc}"
    except TypeError as exc:
        return None if SAYS_TYPE.search(str(exc)) else f"TypeError: {exc}"
    except Exception as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


@pytest.mark.parametrize("name", _public_callables())
@FUZZ
@given(data=st.data())
def test_wrong_types_say_what_was_expected(tmp_path: Path, name: str, data: st.DataObject) -> None:
    obj = getattr(robolobe, name)
    special = st.sampled_from([str(tmp_path), tmp_path, str(tmp_path / "missing" / "x")])
    n_pos, keywords = _required(obj)
    args = [data.draw(st.one_of(wrong, special)) for _ in range(n_pos)]
    kwargs = {k: data.draw(st.one_of(wrong, special)) for k in keywords}
    problem = _problem(obj, args, kwargs)
    assert problem is None, f"{name}(*{args!r}, **{kwargs!r}): {problem}"
