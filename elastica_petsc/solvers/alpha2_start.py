"""The start-up of PETSc 3.18's TSALPHA2, made consistent (docs/model.md §16.4).

On its first step (and after every restart) TSALPHA2 estimates the initial
acceleration A0 from two backward-Euler steps of dt/2 (``TSAlpha_Restart`` in
``src/ts/impls/implicit/alpha/alpha2.c``): with the halved step h = dt/2 in force it
forms A0 = (-3 V0 + 4 V1 - V2) / h, the one-sided difference (-3, 4, -1) / (2h)
without its factor 2, so A0 = 2 a(0) + O(h).  For rho_inf = 1 (the implicit
midpoint member) A0 drops out of X and V; for rho_inf < 1 the error enters through
the spurious root of the alpha recursion and the method converges at first order
at best (measured: order 0.2-0.8 at rho_inf = 0.9 and 0.5 on a first-mode
vibration, 3.7 -> 0.16 as dt halves).

The backward-Euler steps are recognised by the parameters PETSc sets for them,
(alpha_m, alpha_f, gamma, beta) = (1, 1, 1, 1/2), read through ctypes (petsc4py
3.18 has no binding for ``TSAlpha2GetParams``); during them the residual is given
the acceleration 2A (and the Jacobian the shift 2 shift_A), so that the BE
velocities advance by h a / 2 and PETSc's formula yields A0 = a(0) + O(h).
"""
from __future__ import annotations

import ctypes

from .options import petsc_library

START_UP = (1.0, 1.0, 1.0, 0.5)      # TSAlpha_Restart's backward-Euler parameters
_DOUBLE4 = [ctypes.POINTER(ctypes.c_double)] * 4


class Alpha2Params:
    """``params(ts)``: (alpha_m, alpha_f, gamma, beta) of a TSALPHA2 now in force
    (None where the PETSc library cannot be reached: then no correction)."""

    def __init__(self):
        lib = petsc_library()
        self._get = None if lib is None else getattr(lib, "TSAlpha2GetParams", None)
        if self._get is not None:
            self._get.argtypes = [ctypes.c_void_p] + _DOUBLE4
            self._get.restype = ctypes.c_int

    @property
    def available(self) -> bool:
        return self._get is not None

    def params(self, ts) -> tuple[float, float, float, float] | None:
        if self._get is None:
            return None
        vals = [ctypes.c_double() for _ in range(4)]
        if self._get(ctypes.c_void_p(ts.handle), *[ctypes.byref(v) for v in vals]) != 0:
            return None
        return tuple(v.value for v in vals)

    def acceleration_factor(self, ts) -> float:
        """2 during TSALPHA2's backward-Euler start-up, else 1 (module doc)."""
        return 2.0 if self.params(ts) == START_UP else 1.0
