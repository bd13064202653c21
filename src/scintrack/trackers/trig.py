"""Sine, cosine and arctangent of the tracker kernels, in plain IEEE arithmetic (numbers and Lanes alike).

Every tracker evaluates, per trial and epoch, the replica's ``cos`` and ``sin``
(the NCO phase, the EKF's linearisation point) and an ``atan2`` / ``atan``
discriminator.  Called from libm, one lane at a time, these would take ~42 of
the PLL's ~45 ns per filter-epoch; the functions here are written once in
``+ - * /``, ``abs``, :func:`scintrack.simd.lanes.floor` and
:func:`scintrack.simd.lanes.select_less`, so they compile for float64 and,
unchanged, for ``Lanes`` (one SIMD vector of 32 trials: no call, no branch);
the PLL kernel runs ~2.8x faster with them (``docs/performance.md``).

Results do not depend on the machine's libm or instruction set: no libm call,
no fast-math, no FMA contraction (numba emits separate multiplies and adds),
so the bits are the same on every x86-64 and glibc, for a number and for a
lane.  They are not libm's bits: against glibc 2.36 over the test ranges
(``tests/test_trig.py``) ``sincos`` is within 1 ulp (equal in ~97 % of
arguments), ``atan2`` within 2 ulp (equal in ~63 %).

* :func:`sincos` (returns ``(sin x, cos x)``): ``k = floor(2x/pi + 1/2)``;
  ``r = x - k pi/2`` by Cody and Waite's reduction with pi/2 split in three
  27-bit pieces (``k * piece`` exact for ``|k| < 2**26``, i.e. ``|x|`` up to
  ~1.05e8 rad; the first difference exact by Sterbenz's lemma) and a fourth
  piece, the two roundings after the first carried as a tail (Knuth's
  two-sum), so ``r`` is a double-double; then the minimax polynomials of
  Sun Microsystems' fdlibm ``__kernel_sin`` / ``__kernel_cos`` on
  ``|r| <= pi/4`` with the tail's first-order term, and the quadrant ``k mod 4``
  by selects.  Beyond ``|x| ~ 1.05e8`` the reduction is accurate to about the
  argument's own ulp (no tracker phase comes near: 5 kHz for 500 s is 1.6e7).
* :func:`atan2`: the ratio of the smaller to the larger of ``|x|, |y|``; above
  ``tan(pi/8)`` the identity ``atan(a) = pi/4 + atan((a - 1)/(a + 1))`` taken
  as one division ``(mn - mx)/(mn + mx)``, so ``|t| <= tan(pi/8) < 7/16``,
  the range of fdlibm's ``atan`` polynomial (11 coefficients in ``t^2``); then
  ``pi/2 - r``, ``pi - r`` and the sign of ``y`` by selects, pi/4, pi/2 and pi
  as (hi, lo) pairs.  ``atan2(0, 0) = 0``, NaN in gives NaN out, infinities as
  libm except ``atan2(+-inf, +-inf)`` (NaN here, a multiple of pi/4 in libm)
  and signed zeros (``atan2(-0, x)`` is +0 or +pi here).
* :func:`atan` of a quotient ``q / i`` without the division:
  ``atan2(sign(i) q, |i|)`` in [-pi/2, pi/2]; ``i = 0`` gives ``+-pi/2`` by the
  sign of ``q`` (as the Costas discriminator had it), ``q = i = 0`` gives 0.

Constants: pi from Machin's formula in integer arithmetic (240 bits), so its
pieces are computed, not typed; the polynomial coefficients are fdlibm's
published values (k_sin.c, k_cos.c, s_atan.c).
"""

from __future__ import annotations

from fractions import Fraction

from numba import njit

from ..simd.lanes import floor, select_less


def _machin_pi(bits: int = 240) -> Fraction:
    """pi to ``bits`` binary places: 16 atan(1/5) - 4 atan(1/239), series in integers (error < 2**-(bits - 8))."""
    one = 1 << (bits + 16)

    def arctan_inv(n: int) -> int:
        total, term, k, sign = 0, one // n, 1, 1
        while term:
            total += sign * (term // k)
            term //= n * n
            k += 2
            sign = -sign
        return total

    return Fraction(16 * arctan_inv(5) - 4 * arctan_inv(239), one)


def _split(value: Fraction, bits: int) -> tuple[float, Fraction]:
    """``value`` truncated to its leading ``bits`` significant bits (a float, exact), and the rest."""
    e = value.numerator.bit_length() - value.denominator.bit_length()
    while Fraction(2) ** e > value:
        e -= 1
    while Fraction(2) ** (e + 1) <= value:
        e += 1
    q = Fraction(2) ** (e - bits + 1)
    head = Fraction(int(value / q)) * q
    return float(head), value - head


def _hi_lo(value: Fraction) -> tuple[float, float]:
    hi = float(value)
    return hi, float(value - Fraction(hi))


_PI = _machin_pi()
PIO2_1, _r = _split(_PI / 2, 27)
PIO2_2, _r = _split(_r, 27)
PIO2_3, _r = _split(_r, 27)
PIO2_4 = float(_r)
TWO_OVER_PI = float(2 / _PI)
PI4_HI, PI4_LO = _hi_lo(_PI / 4)
PI2_HI, PI2_LO = _hi_lo(_PI / 2)
PI_HI, PI_LO = _hi_lo(_PI)
TAN_PI_8 = 0.41421356237309503  # sqrt(2) - 1, rounded: the switch to atan((a-1)/(a+1))

# fdlibm __kernel_sin / __kernel_cos (|r| <= pi/4) and atan (|t| < 7/16) coefficients
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
T0, T1, T2 = 3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01
T3, T4, T5 = -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02
T6, T7, T8 = 6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02
T9, T10 = -3.65315727442169155270e-02, 1.62858201153657823623e-02

#: operations of one :func:`sincos`, counted from its code: 73 adds, multiplies, negations and
#: floors, and 8 selects at two each (compare and blend); for the flop-limited rates of the benchmarks
SINCOS_OPS = 73 + 2 * 8


@njit(cache=True)
def _two_sum_error(a, b, s):
    """The rounding error of ``s = a + b`` (Knuth's two-sum: ``a + b = s + error`` exactly)."""
    bb = s - a
    return (a - (s - bb)) + (b - bb)


@njit(cache=True)
def sincos(x):
    """``(sin x, cos x)`` (module docstring): within 1 ulp of libm's for ``|x|`` up to ~1.05e8."""
    k = floor(x * TWO_OVER_PI + 0.5)
    a = x - k * PIO2_1  # exact
    m2 = -(k * PIO2_2)
    b = a + m2
    eb = _two_sum_error(a, m2, b)
    m3 = -(k * PIO2_3)
    c = b + m3
    ec = _two_sum_error(b, m3, c)
    tail = (eb + ec) - k * PIO2_4
    r = c + tail  # r + rt = x - k pi/2
    rt = (c - r) + tail
    z = r * r
    v = z * r
    ps = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)))
    s = r - ((z * (0.5 * rt - v * ps) - rt) - v * S1)
    w2 = z * z
    pc = z * (C1 + z * (C2 + z * C3)) + w2 * w2 * (C4 + z * (C5 + z * C6))
    hz = 0.5 * z
    w = 1.0 - hz
    c_ = w + (((1.0 - w) - hz) + (z * pc - r * rt))
    q = k - 4.0 * floor(k * 0.25)  # quadrant 0..3
    odd = select_less(q, 0.5, 0.0, select_less(q, 1.5, 1.0, select_less(q, 2.5, 0.0, 1.0)))
    sin_sign = select_less(q, 1.5, 1.0, -1.0)
    cos_sign = select_less(q, 0.5, 1.0, select_less(q, 2.5, -1.0, 1.0))
    return select_less(odd, 0.5, s, c_) * sin_sign, select_less(odd, 0.5, c_, s) * cos_sign


@njit(cache=True)
def atan2(y, x):
    """Four-quadrant arctangent of ``y / x`` in [-pi, pi] (module docstring): within 2 ulp of libm's."""
    ax = abs(x)
    ay = abs(y)
    mn = select_less(ax, ay, ax, ay)  # NaN-propagating: a NaN lands in mn or mx, then in t
    mx = select_less(ax, ay, ay, ax)
    tm = TAN_PI_8 * mx
    num = select_less(tm, mn, mn - mx, mn)
    den = select_less(tm, mn, mn + mx, mx)
    den = select_less(den, 5e-324, 1.0, den)  # 0 / 0 -> 0
    t = num / den
    z = t * t
    w = z * z
    s1 = z * (T0 + w * (T2 + w * (T4 + w * (T6 + w * (T8 + w * T10)))))
    s2 = w * (T1 + w * (T3 + w * (T5 + w * (T7 + w * T9))))
    hi = select_less(tm, mn, PI4_HI, 0.0)
    lo = select_less(tm, mn, PI4_LO, 0.0)
    r = hi - ((t * (s1 + s2) - lo) - t)
    r = select_less(ax, ay, (PI2_HI - r) + PI2_LO, r)
    r = select_less(x, 0.0, (PI_HI - r) + PI_LO, r)
    return select_less(y, 0.0, -r, r)


@njit(cache=True)
def atan(q, i):
    """``atan(q / i)`` in [-pi/2, pi/2] without dividing: ``atan2(sign(i) q, |i|)`` (``i = 0``: ``+-pi/2`` by q's sign)."""
    return atan2(select_less(i, 0.0, -q, q), abs(i))
