"""Monte Carlo sampling of pin-ring errors, reproducible ring by ring.

Ring k's errors depend only on (seed, k): each error kind of ring k draws from its own
stream ``numpy.random.Generator(PCG64(SeedSequence([seed, k, kind])))``. The results
are therefore bit-for-bit identical however rings are split into chunks and wherever
the chunks run, and changing the distribution of one kind leaves the draws of the
others unchanged. The uniform draws of a batch of rings are computed for all its rings
at once (:func:`uniform_streams`: NumPy's SeedSequence and PCG64 written out over a ring
axis, the same bits as a generator per ring, whose seeding alone cost ~30 µs, 15 % of
a 36-step ring with the compiled kernel); normal draws (NumPy's ziggurat) still take
one generator per ring.

Every distribution is a fixed standard draw times a scale (uniform: U(−1, 1) times the
half range; normal: N(0, 1) times sigma; true position: a point of the unit disc
times the zone radius), so scaling all tolerances by a factor scales the same
underlying draws: common random numbers for :mod:`cyclomesh.tolerance.allocation`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray


class Distribution(Protocol):
    """One error distribution of the ``[tolerance]`` section: ``distribution`` is
    ``"uniform"`` (with ``half_range``) or ``"normal"`` (with ``sigma``), in the unit of
    its key (:class:`cyclomesh.studyfile.schema.Uniform`, ``Normal`` are such objects)."""

    distribution: str


class ToleranceSpec(Protocol):
    """What the sampling reads of the ``[tolerance]`` section: ``seed`` and the optional
    distributions ``radial_um``, ``angular_urad``, ``tangential_um``, ``pin_radius_um``,
    ``eccentricity_um`` and ``position`` (a true-position zone with ``zone_diameter_um``).
    :class:`cyclomesh.studyfile.schema.ToleranceSection` is one; the numerics here do
    not depend on the study-file schema."""

    seed: int


__all__ = ["RingErrors", "draw_ring_errors", "unit_disc", "uniform_streams"]

# stream ids of the error kinds (part of the reproducibility contract: never renumber)
_RADIAL, _ANGULAR, _PIN_RADIUS, _ECCENTRICITY, _POSITION, _TANGENTIAL = 1, 2, 3, 4, 5, 6
_HOLE_RADIAL, _HOLE_TANGENTIAL = 7, 8


@dataclass(frozen=True)
class RingErrors:
    """Errors of a batch of rings in study-file units, leading axis = ring.

    Study-file units (not SI) so that a ring written to a study file as decimal
    numbers reads back bit for bit (see :mod:`cyclomesh.tolerance.worst`).

    Attributes
    ----------
    rings : ndarray, shape (R,)
        Ring indices k.
    radial_um : ndarray, shape (R, n1)
        εa,i, radial pin position error [µm], positive outwards.
    angular_urad : ndarray, shape (R, n1)
        εψ,i, angular pin position error [µrad].
    pin_radius_um : ndarray, shape (R, n1)
        ερ,i, pin radius error [µm].
    eccentricity_um : ndarray, shape (R,)
        εe, eccentricity error [µm].
    hole_radial_um, hole_tangential_um : ndarray, shape (R, D, N), or None
        Crank hole position errors of the RV stage [µm] (disc frame, radial outwards and
        counter-clockwise), drawn per disc and crank; None without a stage.
    """

    rings: NDArray[np.int64]
    radial_um: NDArray[np.float64]
    angular_urad: NDArray[np.float64]
    pin_radius_um: NDArray[np.float64]
    eccentricity_um: NDArray[np.float64]
    hole_radial_um: NDArray[np.float64] | None = None
    hole_tangential_um: NDArray[np.float64] | None = None

    def scaled(self, factor: ArrayLike) -> RingErrors:
        """The same draws times ``factor`` (scalar, or one value per ring) [-]."""
        f = np.asarray(factor, dtype=float)
        fp = f[..., None] if f.ndim else f
        fh = f[..., None, None] if f.ndim else f
        return RingErrors(
            self.rings,
            self.radial_um * fp,
            self.angular_urad * fp,
            self.pin_radius_um * fp,
            self.eccentricity_um * f,
            None if self.hole_radial_um is None else self.hole_radial_um * fh,
            None if self.hole_tangential_um is None else self.hole_tangential_um * fh,
        )

    def take(self, index: ArrayLike) -> RingErrors:
        """The rings at positions ``index`` of this batch."""
        i = np.asarray(index)
        return RingErrors(
            self.rings[i],
            self.radial_um[i],
            self.angular_urad[i],
            self.pin_radius_um[i],
            self.eccentricity_um[i],
            None if self.hole_radial_um is None else self.hole_radial_um[i],
            None if self.hole_tangential_um is None else self.hole_tangential_um[i],
        )


def _stream(seed: int, ring: int, kind: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, ring, kind])))


# --- the streams of many rings at once -----------------------------------------------------
# NumPy's SeedSequence (pool of 4 words) and PCG64 (XSL-RR 128/64), written out over a
# ring axis: constants of numpy/random/bit_generator.pyx and of the PCG64 reference
# (pcg64.h), part of NumPy's stable stream contract (NEP 19).
_U32 = np.uint32
_MASK32 = 0xFFFFFFFF
_INIT_A, _MULT_A = 0x43B0D7E5, 0x931E8875
_INIT_B, _MULT_B = 0x8B51F9DD, 0x58F38DED
_MIX_MULT_L, _MIX_MULT_R = 0xCA01F9DD, 0x4973F715
_XSHIFT = 16
_POOL = 4
_PCG_MULT = (2549297995355413924 << 64) | 4865540595714422341
_MASK64 = (1 << 64) - 1
_MASK128 = (1 << 128) - 1
_DOUBLE_UNIT = 1.0 / 9007199254740992.0  # 2**-53


def _words(n: int) -> list[int]:
    """A non-negative integer as SeedSequence takes it: 32-bit words, lowest first."""
    out = [n & _MASK32] if n == 0 else []
    while n > 0:
        out.append(n & _MASK32)
        n >>= 32
    return out


def _seed_states(seed: int, rings: NDArray[np.int64], kind: int) -> NDArray[np.uint32]:
    """``SeedSequence([seed, k, kind]).generate_state(8, uint32)`` of every ring k < 2**32,
    shape (R, 8): the entropy words of (seed, k, kind) hashed into the pool and drawn out,
    as NumPy's SeedSequence does for one ring (its hash constants do not depend on the
    data, so they are the same Python integers for every ring)."""
    entropy: list[Any] = [*_words(seed), rings.astype(_U32), *_words(kind)]
    const = _INIT_A

    def hashmix(value: Any) -> Any:
        nonlocal const
        value = np.asarray(value, _U32) ^ _U32(const)
        const = (const * _MULT_A) & _MASK32
        value = value * _U32(const)
        return value ^ (value >> _U32(_XSHIFT))

    def mix(x: Any, y: Any) -> Any:
        result = _U32(_MIX_MULT_L) * x - _U32(_MIX_MULT_R) * y
        return result ^ (result >> _U32(_XSHIFT))

    pool = [hashmix(entropy[i] if i < len(entropy) else 0) for i in range(_POOL)]
    for src in range(_POOL):
        for dst in range(_POOL):
            if src != dst:
                pool[dst] = mix(pool[dst], hashmix(pool[src]))
    for src in range(_POOL, len(entropy)):
        for dst in range(_POOL):
            pool[dst] = mix(pool[dst], hashmix(entropy[src]))
    const = _INIT_B
    state = np.empty((rings.size, 2 * _POOL), _U32)
    for dst in range(2 * _POOL):
        value = np.broadcast_to(pool[dst % _POOL], rings.shape) ^ _U32(const)
        const = (const * _MULT_B) & _MASK32
        value = value * _U32(const)
        state[:, dst] = value ^ (value >> _U32(_XSHIFT))
    return state


def _mul64(a: Any, b: Any) -> tuple[Any, Any]:
    """Full product of unsigned 64-bit integers (arrays, wrapping): (high, low) words."""
    m32, s32 = np.uint64(_MASK32), np.uint64(32)
    a0, a1, b0, b1 = a & m32, a >> s32, b & m32, b >> s32
    p00, p01, p10, p11 = a0 * b0, a0 * b1, a1 * b0, a1 * b1
    mid = (p00 >> s32) + (p01 & m32) + (p10 & m32)
    return p11 + (p01 >> s32) + (p10 >> s32) + (mid >> s32), (p00 & m32) | (mid << s32)


def _words128(a: Any) -> tuple[Any, Any]:
    """Python integers (one, or a list) as (high, low) unsigned 64-bit words."""
    values = np.atleast_1d(np.asarray(a, dtype=object))
    return (
        np.array([v >> 64 for v in values], np.uint64),
        np.array([v & _MASK64 for v in values], np.uint64),
    )


def _affine128(x_hi: Any, x_lo: Any, a_hi: Any, a_lo: Any, c_hi: Any, c_lo: Any) -> tuple[Any, Any]:
    """a·x + c mod 2**128 on (high, low) unsigned 64-bit words (arrays, broadcast)."""
    hi, lo = _mul64(x_lo, a_lo)
    hi = hi + x_hi * a_lo + x_lo * a_hi
    lo2 = lo + c_lo
    return hi + c_hi + (lo2 < lo).astype(np.uint64), lo2


def uniform_streams(seed: int, rings: ArrayLike, kind: int, count: int) -> NDArray[np.float64]:
    """The first ``count`` doubles in [0, 1) of every ring's stream, shape (R, count):
    bit for bit ``Generator(PCG64(SeedSequence([seed, k, kind]))).random(count)`` of each
    ring k (0 ≤ k < 2**32), for all rings at once: NumPy's SeedSequence and PCG64 written
    out over a ring axis, every draw j by the generator's jump ahead (state_j = M**j·s +
    (M**(j−1) + … + 1)·inc mod 2**128), the output XSL-RR and the double (x >> 11)·2**−53
    as NumPy's. Much faster than a generator per ring (each costs ~30 µs to seed)."""
    ks = np.asarray(rings, dtype=np.int64).reshape(-1)
    if ks.size and (ks.min() < 0 or ks.max() > _MASK32):
        raise ValueError("uniform_streams: ring indices must lie in [0, 2**32)")
    with np.errstate(over="ignore"):
        words = _seed_states(int(seed), ks, int(kind)).astype(np.uint64)
    s32 = np.uint64(32)
    s_hi, s_lo = words[:, 1] << s32 | words[:, 0], words[:, 3] << s32 | words[:, 2]
    i_hi, i_lo = words[:, 5] << s32 | words[:, 4], words[:, 7] << s32 | words[:, 6]
    # PCG64's seeding (pcg_setseq_128_srandom_r): inc = 2·initseq + 1; state = 0; step;
    # state += initstate; step
    inc_hi = (i_hi << np.uint64(1)) | (i_lo >> np.uint64(63))
    inc_lo = (i_lo << np.uint64(1)) | np.uint64(1)
    m_hi, m_lo = _words128(_PCG_MULT)
    lo = inc_lo + s_lo  # one step from 0 is inc; plus the initial state
    x_hi, x_lo = inc_hi + s_hi + (lo < inc_lo).astype(np.uint64), lo
    x_hi, x_lo = _affine128(x_hi, x_lo, m_hi, m_lo, inc_hi, inc_lo)  # the seeded state
    mult, add = [], []  # state after j + 1 steps: mult_j·x + add_j·inc
    m, c = 1, 0
    for _ in range(count):
        m, c = (m * _PCG_MULT) & _MASK128, (c * _PCG_MULT + 1) & _MASK128
        mult.append(m)
        add.append(c)
    zero = np.uint64(0)
    c_hi, c_lo = _affine128(inc_hi[:, None], inc_lo[:, None], *_words128(add), zero, zero)
    hi, lo = _affine128(x_hi[:, None], x_lo[:, None], *_words128(mult), c_hi, c_lo)
    value, rot = hi ^ lo, hi >> np.uint64(58)  # XSL-RR: rotate right by the top 6 bits
    value = (value >> rot) | (value << ((np.uint64(64) - rot) & np.uint64(63)))
    return (value >> np.uint64(11)).astype(np.float64) * _DOUBLE_UNIT


def unit_disc(rng: np.random.Generator, size: int) -> tuple[NDArray[np.float64], ...]:
    """Points uniform in area over the unit disc: r = sqrt(U1), θ = 2π·U2.

    Returns
    -------
    x, y : ndarray
        Cartesian coordinates [-] (x radial, y tangential for a pin).
    """
    u = rng.random((2, size))
    r = np.sqrt(u[0])
    theta = 2.0 * np.pi * u[1]
    return r * np.cos(theta), r * np.sin(theta)


def _standard(dist: Any, rng: np.random.Generator, size: int) -> NDArray[np.float64]:
    if dist.distribution == "uniform":
        return rng.uniform(-1.0, 1.0, size) * dist.half_range
    if dist.distribution == "normal":
        return rng.standard_normal(size) * dist.sigma
    raise ValueError(f"unknown distribution {dist.distribution!r}")


def _fast(ks: NDArray[np.int64]) -> bool:
    """Whether :func:`uniform_streams` takes these rings (indices in [0, 2**32))."""
    return not ks.size or (ks.min() >= 0 and ks.max() <= _MASK32)


def _draws(
    dist: Any, seed: int, ks: NDArray[np.int64], kind: int, size: int
) -> NDArray[np.float64]:
    """The standard draws of ``dist`` times its scale for every ring, shape (R, size):
    ring k's are ``_standard(dist, _stream(seed, k, kind), size)``, bit for bit; a uniform
    distribution takes all rings' streams at once (:func:`uniform_streams`:
    U(−1, 1) = −1 + 2·u, as NumPy's ``Generator.uniform``), a normal one (NumPy's
    ziggurat) one generator per ring."""
    if dist.distribution == "uniform" and _fast(ks):
        return (-1.0 + 2.0 * uniform_streams(seed, ks, kind, size)) * dist.half_range
    out = np.empty((ks.size, size))
    for j, k in enumerate(ks.tolist()):
        out[j] = _standard(dist, _stream(seed, k, kind), size)
    return out


def _unit_discs(seed: int, ks: NDArray[np.int64], pins: int) -> tuple[NDArray[np.float64], ...]:
    """:func:`unit_disc` of every ring's true-position stream, shape (R, pins) each."""
    if not _fast(ks):
        points = [unit_disc(_stream(seed, k, _POSITION), pins) for k in ks.tolist()]
        return tuple(np.array([p[i] for p in points]).reshape(ks.size, pins) for i in (0, 1))
    u = uniform_streams(seed, ks, _POSITION, 2 * pins)  # rng.random((2, pins)) row by row
    r = np.sqrt(u[:, :pins])
    theta = 2.0 * np.pi * u[:, pins:]
    return r * np.cos(theta), r * np.sin(theta)


def draw_ring_errors(
    spec: ToleranceSpec | Any,
    pins: int,
    pin_circle_radius: float,
    rings: Sequence[int] | NDArray[np.integer],
    holes: tuple[int, int] | None = None,
) -> RingErrors:
    """Draw the errors of the given rings at the stated tolerances (scale factor 1).

    Parameters
    ----------
    spec : ToleranceSpec
        Distributions and seed (the ``[tolerance]`` section).
    pins : int
        Number of pins n1 [-].
    pin_circle_radius : float
        Pin-circle radius a [m], to turn a tangential error (``tangential_um`` or the
        true-position zone's) into the angular error εψ,i = tangential / a.
    rings : sequence of int
        Ring indices k ≥ 0.
    holes : (D, N), optional
        Discs and crank holes of an RV stage: the crank hole errors ``hole_radial_um`` and
        ``hole_tangential_um`` of the spec are drawn per disc and crank (streams of their
        own, same distributions as the pin errors); None: no hole errors.

    Returns
    -------
    RingErrors
        In µm and µrad.
    """
    ks = np.asarray(rings, dtype=np.int64).reshape(-1)
    n = ks.size
    zeros = np.zeros((n, pins))
    radial, angular, pin_radius, eccentricity = zeros, zeros.copy(), zeros.copy(), np.zeros(n)
    seed = spec.seed
    if spec.radial_um is not None:
        radial = _draws(spec.radial_um, seed, ks, _RADIAL, pins)
    if spec.angular_urad is not None:
        angular = _draws(spec.angular_urad, seed, ks, _ANGULAR, pins)
    if spec.tangential_um is not None:  # µm / m = µrad
        angular = _draws(spec.tangential_um, seed, ks, _TANGENTIAL, pins) / pin_circle_radius
    if spec.position is not None:
        x, y = _unit_discs(seed, ks, pins)
        radius_um = 0.5 * spec.position.zone_diameter_um
        radial = radius_um * x
        angular = radius_um * y / pin_circle_radius  # µm / m = µrad
    if spec.pin_radius_um is not None:
        pin_radius = _draws(spec.pin_radius_um, seed, ks, _PIN_RADIUS, pins)
    if spec.eccentricity_um is not None:
        eccentricity = _draws(spec.eccentricity_um, seed, ks, _ECCENTRICITY, 1)[:, 0]
    if holes is None:
        return RingErrors(ks, radial, angular, pin_radius, eccentricity)
    hole = {}
    for name, kind in (("hole_radial_um", _HOLE_RADIAL), ("hole_tangential_um", _HOLE_TANGENTIAL)):
        hole[name] = np.zeros((n, *holes))
        dist = getattr(spec, name, None)
        if dist is not None:
            hole[name] = _draws(dist, seed, ks, kind, holes[0] * holes[1]).reshape(n, *holes)
    return RingErrors(ks, radial, angular, pin_radius, eccentricity, **hole)
