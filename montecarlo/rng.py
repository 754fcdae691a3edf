"""Per-block random numbers for the kernels: xoshiro256+ uniforms and ziggurat normals.

numba's ``np.random.standard_normal`` costs ~29 ns on this machine, about the whole budget
of one time step; this generator costs ~1.8 ns a normal. Each block owns its own state
(four uint64 words from ``numpy.random.SeedSequence``), so nothing is shared between threads.
The state is threaded through the calls as four scalars, returned with each value: a numba
function that takes an array argument and is not inlined pays reference counting on every
call (measured: 16 ns with the state in an array, 50 ns with the tables as arguments too).

- xoshiro256+ (Blackman & Vigna): 64-bit output; the upper 53 bits give a double in (0, 1).
- normals: the 128-layer ziggurat of Marsaglia & Tsang (J. Stat. Softw. 5(8), 2000). The
  layer index is taken from the low 7 bits and the signed 32-bit value from the high 32 bits
  of the same 64-bit draw. These bits are independent, which avoids the index/value
  correlation of the original (Leong et al., J. Stat. Softw. 12(7), 2005).
The quality is tested in tests/test_montecarlo.py (moments, tails, KS, lag correlation).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit

R_TAIL = 3.442619855899
_M1 = 2147483648.0
_U53 = 1.0 / 9007199254740992.0
U64 = np.uint64


def ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(kn, wn, fn) of the 128-layer ziggurat (Marsaglia & Tsang's zigset)."""
    kn = np.zeros(128, dtype=np.int64)
    wn = np.zeros(128)
    fn = np.zeros(128)
    dn = tn = R_TAIL
    vn = 9.91256303526217e-3
    q = vn / math.exp(-0.5 * dn * dn)
    kn[0] = int((dn / q) * _M1)
    kn[1] = 0
    wn[0] = q / _M1
    wn[127] = dn / _M1
    fn[0] = 1.0
    fn[127] = math.exp(-0.5 * dn * dn)
    for i in range(126, 0, -1):
        dn = math.sqrt(-2.0 * math.log(vn / dn + math.exp(-0.5 * dn * dn)))
        kn[i + 1] = int((dn / tn) * _M1)
        tn = dn
        fn[i] = math.exp(-0.5 * dn * dn)
        wn[i] = dn / _M1
    return kn, wn, fn


# module-level tables are frozen into the compiled code as constants
KN, WN, FN = ziggurat_tables()


def states_from_seed(seed: int, blocks: int) -> np.ndarray:
    """(blocks, 4) uint64 xoshiro states from SeedSequence(seed).spawn(blocks)."""
    out = np.empty((blocks, 4), dtype=np.uint64)
    for b, child in enumerate(np.random.SeedSequence(seed).spawn(blocks)):
        s = child.generate_state(4, dtype=np.uint64)
        if not s.any():  # the all-zero state is a fixed point
            s[0] = U64(1)
        out[b] = s
    return out


def block_seeds(seed: int, blocks: int, per_block: int = 1, key: int = 0) -> np.ndarray:
    """(blocks, per_block, 4) uint64 xoshiro states: block b from the state words of
    SeedSequence(seed, spawn_key=(key + b,)), i.e. the b-th child of SeedSequence(seed)."""
    out = np.empty((blocks, per_block, 4), dtype=np.uint64)
    for b in range(blocks):
        words = np.random.SeedSequence(seed, spawn_key=(key + b,)).generate_state(
            4 * per_block, dtype=np.uint64).reshape(per_block, 4)
        words[~words.any(axis=1), 0] = 1  # the all-zero state is a fixed point
        out[b] = words
    return out


@jit(inline="always")
def next_u64(s0, s1, s2, s3):
    """xoshiro256+: (64 random bits, new state)."""
    result = s0 + s3
    t = s1 << U64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = (s3 << U64(45)) | (s3 >> U64(19))
    return result, s0, s1, s2, s3


@jit(inline="always")
def uniform(s0, s1, s2, s3):
    """(a double in (0, 1), new state): the upper 53 bits, offset by half a unit."""
    u, s0, s1, s2, s3 = next_u64(s0, s1, s2, s3)
    return ((u >> U64(11)) + 0.5) * _U53, s0, s1, s2, s3


@jit
def _slow(u, s0, s1, s2, s3):
    """The ziggurat's rejection and tail path (~3% of draws)."""
    while True:
        iz = np.int64(u & U64(127))
        hz = np.int64(np.int32(np.uint32(u >> U64(32))))
        if abs(hz) < KN[iz]:
            return hz * WN[iz], s0, s1, s2, s3
        x = hz * WN[iz]
        if iz == 0:
            while True:
                a, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
                b, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
                xt = -math.log(a) / R_TAIL
                if -2.0 * math.log(b) >= xt * xt:
                    break
            return (R_TAIL + xt if hz > 0 else -R_TAIL - xt), s0, s1, s2, s3
        a, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
        if FN[iz] + a * (FN[iz - 1] - FN[iz]) < math.exp(-0.5 * x * x):
            return x, s0, s1, s2, s3
        u, s0, s1, s2, s3 = next_u64(s0, s1, s2, s3)


@jit
def normal(s0, s1, s2, s3):
    """(a standard normal, new state) by the 128-layer ziggurat."""
    u, s0, s1, s2, s3 = next_u64(s0, s1, s2, s3)
    iz = np.int64(u & U64(127))
    hz = np.int64(np.int32(np.uint32(u >> U64(32))))
    if abs(hz) < KN[iz]:
        return hz * WN[iz], s0, s1, s2, s3
    return _slow(u, s0, s1, s2, s3)


@jit
def fill_normals(state, out) -> None:
    """out[:] = normals from the state (uint64[4], advanced in place): a test helper."""
    s0, s1, s2, s3 = state[0], state[1], state[2], state[3]
    for i in range(out.size):
        out[i], s0, s1, s2, s3 = normal(s0, s1, s2, s3)
    state[0], state[1], state[2], state[3] = s0, s1, s2, s3
