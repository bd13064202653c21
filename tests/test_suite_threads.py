"""The suite's own set-up: an xdist worker's linear-algebra pools are its share of the cores
(``conftest._one_blas_pool_per_core``), set before numpy loads OpenBLAS."""

from __future__ import annotations

import os

import conftest
import pytest


def test_blas_pools_are_set_before_numpy_loads():
    assert not conftest.NUMPY_BEFORE_CONFTEST  # else OpenBLAS sized its pool before the variables were set


@pytest.mark.skipif("PYTEST_XDIST_WORKER_COUNT" not in os.environ, reason="only an xdist worker sizes its pools")
def test_an_xdist_worker_uses_its_share_of_the_cores(monkeypatch):
    expected = str(max(1, (os.cpu_count() or 1) // int(os.environ["PYTEST_XDIST_WORKER_COUNT"])))
    for var in conftest.BLAS_VARIABLES:
        assert os.environ[var] == (conftest.USER_BLAS[var] or expected), var
        monkeypatch.delenv(var)
    conftest._one_blas_pool_per_core()
    assert all(os.environ[v] == expected for v in conftest.BLAS_VARIABLES)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "7")
    conftest._one_blas_pool_per_core()
    assert os.environ["OPENBLAS_NUM_THREADS"] == "7"  # a value the user set is kept
