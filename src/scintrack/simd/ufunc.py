"""The numpy ufunc of a scalar formula, compiled on first call.

``LazyUfunc(py, signatures)`` is ``numba.vectorize(signatures, cache=True)``
of the Python function ``py``, the same function that ``njit`` compiles for
the kernels, so the array form and the scalar form share one formula.  It is
built on first call, so that importing a module of formulas compiles nothing.

The ufunc is compiled from a copy of ``py`` named ``<name>_ufunc``: numba names
a cache file after a function's qualified name and first line, so the copy's
entries live in a cache file of their own instead of sharing one index with
the ``njit`` function's entries of the same argument types.
"""

from __future__ import annotations

import types

from numba import vectorize

#: ufunc signatures of the float64 formulas of two and three arguments
F8_2 = ["float64(float64, float64)"]
F8_3 = ["float64(float64, float64, float64)"]


class LazyUfunc:
    """``numba.vectorize(signatures, cache=True)(py)``, built on first call."""

    def __init__(self, py, signatures):
        self.py, self.signatures, self._ufunc = py, signatures, None
        self.__doc__ = f"Array (ufunc) form of :func:`{py.__name__.lstrip('_')}`."

    def build(self) -> None:
        """Build the ufunc now (its element kernel from the numba cache, its loop wrapper compiled)."""
        if self._ufunc is None:
            self._ufunc = vectorize(self.signatures, cache=True)(_renamed(self.py, "_ufunc"))

    def __call__(self, *args):
        self.build()
        return self._ufunc(*args)


def _renamed(py, suffix: str):
    """A copy of the function ``py`` (same code, globals, defaults) whose name and qualified name end in ``suffix``."""
    f = types.FunctionType(py.__code__, py.__globals__, py.__name__ + suffix, py.__defaults__, py.__closure__)
    f.__qualname__ = py.__qualname__ + suffix
    f.__module__ = py.__module__
    f.__doc__ = py.__doc__
    return f
