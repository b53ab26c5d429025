"""Monte Carlo sampling of pin-ring errors, reproducible ring by ring.

Ring k's errors depend only on (seed, k): each error kind of ring k draws from its own
stream ``numpy.random.Generator(PCG64(SeedSequence([seed, k, kind])))``. The results
are therefore bit-for-bit identical however rings are split into chunks and wherever
the chunks run, and changing the distribution of one kind leaves the draws of the
others unchanged.

Every distribution is a fixed standard draw times a scale (uniform: U(−1, 1) times the
half range; normal: N(0, 1) times sigma; true position: a point of the unit disc
times the zone radius), so scaling all tolerances by a factor scales the same
underlying draws: common random numbers for :mod:`cyclomesh.tolerance.allocation`.

Uniform draws (``uniform`` and the true-position zone) of a batch of rings are taken
all at once (:func:`uniform_doubles`): NumPy's ``SeedSequence`` hash and its PCG64
generator (XSL-RR output of a 128-bit LCG, jumped ahead to every draw) in integer array
arithmetic over the rings, which gives the bits of the per-ring generators exactly
(tests compare them); normal draws take the per-ring generators.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
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


__all__ = ["RingErrors", "draw_ring_errors", "unit_disc", "uniform_doubles"]

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


# NumPy's SeedSequence (numpy/random/bit_generator.pyx) and PCG64 (pcg64.h) constants
_M32 = 0xFFFFFFFF
_M64 = 0xFFFFFFFFFFFFFFFF
_POOL = 4
_INIT_A, _MULT_A, _INIT_B, _MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R = 0xCA01F9DD, 0x4973F715
_PCG_MULT = (2549297995355413924 << 64) + 4865540595714422341
_TWO_POW_MINUS_53 = 1.0 / 9007199254740992.0


def _words(n: int) -> list[int]:
    """An entropy integer as SeedSequence takes it: 32-bit words, least significant first
    ([0] for 0)."""
    out = [n & _M32]
    n >>= 32
    while n:
        out.append(n & _M32)
        n >>= 32
    return out


def _hashmix(value: NDArray[np.uint64], const: list[int]) -> NDArray[np.uint64]:
    value = value ^ np.uint64(const[0])
    const[0] = (const[0] * _MULT_A) & _M32
    value = (value * np.uint64(const[0])) & np.uint64(_M32)
    return value ^ (value >> np.uint64(16))


def _mix(x: NDArray[np.uint64], y: NDArray[np.uint64]) -> NDArray[np.uint64]:
    result = (np.uint64(_MIX_L) * x - np.uint64(_MIX_R) * y) & np.uint64(_M32)
    return result ^ (result >> np.uint64(16))


def _pool(entropy: NDArray[np.uint64]) -> list[NDArray[np.uint64]]:
    """SeedSequence's entropy pool (4 words) of every row of ``entropy`` (R, L)."""
    const = [_INIT_A]
    zero = np.zeros(entropy.shape[0], np.uint64)
    mixer = [_hashmix(entropy[:, i] if i < entropy.shape[1] else zero, const) for i in range(_POOL)]
    for src in range(_POOL):
        for dst in range(_POOL):
            if src != dst:
                mixer[dst] = _mix(mixer[dst], _hashmix(mixer[src], const))
    for src in range(_POOL, entropy.shape[1]):
        for dst in range(_POOL):
            mixer[dst] = _mix(mixer[dst], _hashmix(entropy[:, src], const))
    return mixer


def _generate_state(pool: list[NDArray[np.uint64]], words: int) -> list[NDArray[np.uint64]]:
    """SeedSequence.generate_state(words, uint32) of every row, word by word."""
    const = _INIT_B
    out = []
    for i in range(words):
        value = pool[i % _POOL] ^ np.uint64(const)
        const = (const * _MULT_B) & _M32
        value = (value * np.uint64(const)) & np.uint64(_M32)
        out.append(value ^ (value >> np.uint64(16)))
    return out


def _mulhi(a: NDArray[np.uint64], b: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """High 64 bits of the 128-bit product of two uint64 arrays."""
    m, s = np.uint64(_M32), np.uint64(32)
    a0, a1, b0, b1 = a & m, a >> s, b & m, b >> s
    p01, p10 = a0 * b1, a1 * b0
    mid = ((a0 * b0) >> s) + (p01 & m) + (p10 & m)
    return a1 * b1 + (p01 >> s) + (p10 >> s) + (mid >> s)


def _mul128(ah, al, bh, bl):  # type: ignore[no-untyped-def]
    """(a·b) mod 2^128 of 128-bit numbers held as (high, low) uint64 arrays."""
    return _mulhi(al, bl) + al * bh + ah * bl, al * bl


def _add128(ah, al, bh, bl):  # type: ignore[no-untyped-def]
    low = al + bl
    return ah + bh + (low < al).astype(np.uint64), low


def _split(values: list[int]) -> tuple[NDArray[np.uint64], NDArray[np.uint64]]:
    return (
        np.array([v >> 64 for v in values], np.uint64),
        np.array([v & _M64 for v in values], np.uint64),
    )


@cache
def _jumps(count: int) -> tuple[NDArray[np.uint64], ...]:
    """The LCG from its state after seeding to the state of draw j = 1 .. count:
    state_j = A_j·state_0 + C_j·inc (mod 2^128), A_j = M^j, C_j = Σ_{i<j} M^i; as
    (high, low) uint64 arrays of shape (count,)."""
    mod = 1 << 128
    a, c, powers, sums = 1, 0, [], []
    for _ in range(count):
        c = (c + a) % mod
        a = (a * _PCG_MULT) % mod
        powers.append(a)
        sums.append(c)
    return (*_split(powers), *_split(sums))


def uniform_doubles(seed: int, rings: Sequence[int], kind: int, count: int) -> NDArray | None:
    """The first ``count`` doubles in [0, 1) of the stream (seed, k, kind) of every ring
    k, shape (R, count): bit for bit ``_stream(seed, k, kind).random(count)`` (module
    doc), or None where the integer arithmetic does not apply (a ring index of 2^32 or
    more, a negative seed): the caller takes the per-ring generators.

    SeedSequence([seed, k, kind]) hashes the 32-bit words of its entropy into a pool of 4
    words and generates the 4 × 64 bits of PCG64's seed (initial state and increment);
    PCG64 seeds its 128-bit LCG (state = (inc + initstate)·M + inc, inc = 2·initseq + 1)
    and steps it before every output, the XSL-RR permutation of the state; a double is
    the output's top 53 bits times 2^−53.
    """
    ks = [int(k) for k in rings]
    if seed < 0 or any(k < 0 or k > _M32 for k in ks):
        return None
    fixed = _words(int(seed))
    entropy = np.empty((len(ks), len(fixed) + 2), np.uint64)
    entropy[:, : len(fixed)] = fixed
    entropy[:, len(fixed)] = ks
    entropy[:, len(fixed) + 1] = kind
    w = _generate_state(_pool(entropy), 8)
    s32 = np.uint64(32)
    # generate_state(4, uint64): little-endian pairs of the 8 words
    init_h, init_l = w[0] | (w[1] << s32), w[2] | (w[3] << s32)
    seq_h, seq_l = w[4] | (w[5] << s32), w[6] | (w[7] << s32)
    one = np.uint64(1)
    inc_h = (seq_h << one) | (seq_l >> np.uint64(63))
    inc_l = (seq_l << one) | one
    mult_h, mult_l = (np.uint64(v) for v in (_PCG_MULT >> 64, _PCG_MULT & _M64))
    state = _add128(*_mul128(*_add128(inc_h, inc_l, init_h, init_l), mult_h, mult_l), inc_h, inc_l)
    a_h, a_l, c_h, c_l = _jumps(count)
    col = (slice(None), None)
    step = _add128(
        *_mul128(state[0][col], state[1][col], a_h, a_l),
        *_mul128(inc_h[col], inc_l[col], c_h, c_l),
    )
    high, low = step
    x = high ^ low
    rot = high >> np.uint64(58)
    out = (x >> rot) | (x << ((np.uint64(64) - rot) & np.uint64(63)))
    return (out >> np.uint64(11)).astype(np.float64) * _TWO_POW_MINUS_53


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
    radial = np.zeros((n, pins))
    angular = np.zeros((n, pins))
    pin_radius = np.zeros((n, pins))
    eccentricity = np.zeros(n)
    seed = spec.seed
    if spec.radial_um is not None:
        radial[:] = _draws(spec.radial_um, seed, ks, _RADIAL, pins)
    if spec.angular_urad is not None:
        angular[:] = _draws(spec.angular_urad, seed, ks, _ANGULAR, pins)
    if spec.tangential_um is not None:  # µm / m = µrad
        angular[:] = _draws(spec.tangential_um, seed, ks, _TANGENTIAL, pins) / pin_circle_radius
    if spec.position is not None:
        x, y = _unit_discs(seed, ks, pins)
        radius_um = 0.5 * spec.position.zone_diameter_um
        radial[:] = radius_um * x
        angular[:] = radius_um * y / pin_circle_radius  # µm / m = µrad
    if spec.pin_radius_um is not None:
        pin_radius[:] = _draws(spec.pin_radius_um, seed, ks, _PIN_RADIUS, pins)
    if spec.eccentricity_um is not None:
        eccentricity[:] = _draws(spec.eccentricity_um, seed, ks, _ECCENTRICITY, 1)[:, 0]
    if holes is None:
        return RingErrors(ks, radial, angular, pin_radius, eccentricity)
    hole = {}
    for name, kind in (("hole_radial_um", _HOLE_RADIAL), ("hole_tangential_um", _HOLE_TANGENTIAL)):
        hole[name] = np.zeros((n, *holes))
        dist = getattr(spec, name, None)
        if dist is not None:
            size = holes[0] * holes[1]
            hole[name][:] = _draws(dist, seed, ks, kind, size).reshape(n, *holes)
    return RingErrors(ks, radial, angular, pin_radius, eccentricity, **hole)


def _draws(dist: Any, seed: int, ks: NDArray[np.int64], kind: int, size: int) -> NDArray:
    """``_standard(dist, _stream(seed, k, kind), size)`` of every ring k, shape (R, size):
    a uniform distribution from :func:`uniform_doubles` (Generator.uniform(−1, 1) is
    −1 + 2·u), the rest ring by ring."""
    if dist.distribution == "uniform":
        u = uniform_doubles(seed, ks.tolist(), kind, size)
        if u is not None:
            return (-1.0 + 2.0 * u) * dist.half_range
    out = np.empty((ks.size, size))
    for j, k in enumerate(ks.tolist()):
        out[j] = _standard(dist, _stream(seed, k, kind), size)
    return out


def _unit_discs(seed: int, ks: NDArray[np.int64], pins: int) -> tuple[NDArray, NDArray]:
    """:func:`unit_disc` of the stream (seed, k, :data:`_POSITION`) of every ring k, shape
    (R, pins) each (its ``random((2, pins))``: the first ``pins`` doubles are U1)."""
    u = uniform_doubles(seed, ks.tolist(), _POSITION, 2 * pins)
    if u is None:
        x, y = np.empty((ks.size, pins)), np.empty((ks.size, pins))
        for j, k in enumerate(ks.tolist()):
            x[j], y[j] = unit_disc(_stream(seed, k, _POSITION), pins)
        return x, y
    r = np.sqrt(u[:, :pins])
    theta = 2.0 * np.pi * u[:, pins:]
    return r * np.cos(theta), r * np.sin(theta)
