"""Periodic cubic spline on uniform samples (numpy only, so `hardware` can use it)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class PeriodicSpline:
    """C² periodic cubic interpolant of `values` (N × D) sampled at phases k/N, k = 0..N−1."""

    values: np.ndarray
    second: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        y = np.atleast_2d(np.asarray(self.values, dtype=float))
        if y.shape[0] == 1 and np.ndim(self.values) == 1:
            y = y.T
        n = y.shape[0]
        if n < 3:
            raise ValueError("a periodic spline needs at least 3 samples")
        h = 1.0 / n
        # cyclic tridiagonal system M[i-1] + 4 M[i] + M[i+1] = 6/h² (y[i-1] − 2 y[i] + y[i+1])
        a = 4.0 * np.eye(n) + np.roll(np.eye(n), 1, axis=1) + np.roll(np.eye(n), -1, axis=1)
        rhs = 6.0 / h**2 * (np.roll(y, 1, axis=0) - 2.0 * y + np.roll(y, -1, axis=0))
        object.__setattr__(self, "values", y)
        object.__setattr__(self, "second", np.linalg.solve(a, rhs))

    def _locate(self, phase: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = self.values.shape[0]
        s = np.mod(phase, 1.0) * n
        i = np.minimum(np.floor(s).astype(int), n - 1)
        return i, (i + 1) % n, s - i

    def __call__(self, phase: float | np.ndarray) -> np.ndarray:
        """Values at `phase` (scalar → (D,), array (K,) → (K, D)); phase wraps modulo 1."""
        p = np.asarray(phase, dtype=float)
        i, j, u = self._locate(np.atleast_1d(p))
        h = 1.0 / self.values.shape[0]
        u = u[:, None]
        y, m = self.values, self.second
        out = (
            (1 - u) * y[i]
            + u * y[j]
            + h**2 / 6.0 * (((1 - u) ** 3 - (1 - u)) * m[i] + (u**3 - u) * m[j])
        )
        return out[0] if p.ndim == 0 else out

    def derivative(self, phase: float | np.ndarray) -> np.ndarray:
        """d(values)/d(phase) at `phase` (divide by the period for a time derivative)."""
        p = np.asarray(phase, dtype=float)
        i, j, u = self._locate(np.atleast_1d(p))
        n = self.values.shape[0]
        h = 1.0 / n
        u = u[:, None]
        y, m = self.values, self.second
        out = (y[j] - y[i]) / h + h / 6.0 * (-(3 * (1 - u) ** 2 - 1) * m[i] + (3 * u**2 - 1) * m[j])
        return out[0] if p.ndim == 0 else out
