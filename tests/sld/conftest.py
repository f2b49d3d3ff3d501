"""Fixtures of the sld tests: the reference system in three flavours."""

from __future__ import annotations

import pytest

from robolobe.sld import ModalModel

from .sld_reference import F_N, K_MODAL, ZETA


@pytest.fixture(scope="session")
def one_dof_x() -> ModalModel:
    """Flexible in the feed direction x only."""
    return ModalModel.from_directional([F_N], [ZETA], [K_MODAL], ["xx"])


@pytest.fixture(scope="session")
def one_dof_y() -> ModalModel:
    """Flexible in the normal direction y only."""
    return ModalModel.from_directional([F_N], [ZETA], [K_MODAL], ["yy"])


@pytest.fixture(scope="session")
def iso_2dof() -> ModalModel:
    """The same mode in x and y."""
    return ModalModel.isotropic([F_N], [ZETA], [K_MODAL])
