"""Sine, cosine and tangent from IEEE-754 additions and products alone: the same bits on every CPU.

``np.sin`` and ``np.cos`` are not the same function on every machine: numpy picks a SIMD implementation per CPU
(AVX-512 machines use Intel's SVML, whose last bits differ from glibc's: numpy issue #23523), and glibc picks an
FMA or a plain variant of its own. A grasp's pose is a sine and a cosine of a random angle away from its simulated
outcome, and pybullet turns one ULP into a different contact now and then: the paper experiment's 70,944 extracted
grasps came out as 70,940 on another CPU. Every angle that feeds a pose, a camera or a trajectory goes through
these functions instead: Cody-Waite reduction by pi/2 (fdlibm's split constants, exact for |x| < 2**20 * pi/2)
and fdlibm's minimax polynomials on [-pi/4, pi/4], written as separate numpy products and sums, which IEEE-754
rounds the same way on every CPU and SIMD width. Accuracy: within 1 ULP of the true value for |x| < 1e5.
"""

from __future__ import annotations

import numpy as np

_INV_PIO2 = 6.36619772367581382433e-01  # 2 / pi
_PIO2_1 = 1.57079632673412561417e00  # first 33 bits of pi / 2: n * _PIO2_1 is exact for |n| < 2**20
_PIO2_1T = 6.07710050650619224932e-11  # pi / 2 - _PIO2_1
_LARGEST = 1.0e5
_SIN = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
        2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_COS = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
        -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)


def _horner(z: np.ndarray, coefficients: tuple[float, ...]) -> np.ndarray:
    """c0 + z * (c1 + z * (c2 + ...)), one rounded product and one rounded sum at a time. -> like z"""
    out = np.full_like(z, coefficients[-1])
    for c in coefficients[-2::-1]:
        out = c + z * out
    return out


def _reduce(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x = n * pi / 2 + r + tail with |r| <= pi / 4 (to rounding) and tail r's rounding error:
    (r float64, tail float64, n mod 4 int64), each like x."""
    if not np.all(np.abs(x) < _LARGEST):
        bad = x[~(np.abs(x) < _LARGEST)].ravel()[0]
        raise ValueError(f"angle {bad!r} rad: portable sine and cosine take finite angles below {_LARGEST:g} rad")
    n = np.rint(x * _INV_PIO2)
    exact = x - n * _PIO2_1
    w = n * _PIO2_1T
    r = exact - w
    return r, (exact - r) - w, n.astype(np.int64) & 3


def sin_cos(angle: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Sine and cosine of ``angle`` (any shape, radians, |angle| < 1e5), float64, the same bits on every CPU.
    -> (sin, cos), each shaped like ``angle``"""
    x = np.asarray(angle, dtype=np.float64)
    r, tail, quadrant = _reduce(x)
    z = r * r
    v = z * r
    sin_r = r - ((z * (0.5 * tail - v * _horner(z, _SIN[1:])) - tail) - v * _SIN[0])
    half = 0.5 * z
    w = 1.0 - half
    cos_r = w + (((1.0 - w) - half) + ((z * z) * _horner(z, _COS) - r * tail))
    sin = np.select([quadrant == 0, quadrant == 1, quadrant == 2], [sin_r, cos_r, -sin_r], -cos_r)
    cos = np.select([quadrant == 0, quadrant == 1, quadrant == 2], [cos_r, -sin_r, -cos_r], sin_r)
    return sin, cos


def sin(angle: np.ndarray | float) -> np.ndarray:
    """``sin_cos(angle)[0]``: float64 like ``angle``."""
    return sin_cos(angle)[0]


def cos(angle: np.ndarray | float) -> np.ndarray:
    """``sin_cos(angle)[1]``: float64 like ``angle``."""
    return sin_cos(angle)[1]


def tan(angle: np.ndarray | float) -> np.ndarray:
    """Tangent as sine / cosine (one more correctly rounded division): float64 like ``angle``."""
    s, c = sin_cos(angle)
    return s / c
