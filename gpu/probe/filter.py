#!/usr/bin/env python3
"""How a device filters rgba16float 3-D textures, against the raymarch envelope's filter model (DESIGN.md §12.5.1).

Reads what `node gpu/probe/probe.mjs OUTDIR` wrote (queries.f32, texA.f16 / texB.f16, filterA.f32 / filterB.f32) and
prints, per texture, the largest |GPU - exact trilinear| in units of the 8 texels' spread / 256 (after half a binary16
ulp of the result), whether results look rounded to binary16, and how many samples fall outside the model
(3 (2^-9 + 2^-12) x spread + one binary16 ulp of the largest texel). Exit 0 when every sample fits, 1 otherwise, 2 on
bad input. No dependencies beyond Python 3.
"""
import itertools
import math
import struct
import sys

N = 8
WEIGHT_ERR = 2.0 ** -9 + 2.0 ** -12


def floats(path, fmt):
    with open(path, 'rb') as f:
        b = f.read()
    size = struct.calcsize(fmt)
    if len(b) % size:
        raise ValueError(f'{path}: {len(b)} bytes is not a whole number of {fmt} values')
    return struct.unpack(f'<{len(b) // size}{fmt}', b)


def ulp16(v):
    v = abs(v)
    return 2.0 ** (math.floor(math.log2(v)) - 10) if v >= 2.0 ** -14 else 2.0 ** -24


def corners(tex, q, c):
    g = [q[a] * N - 0.5 for a in range(3)]
    i0 = [math.floor(x) for x in g]
    f = [g[a] - i0[a] for a in range(3)]
    exact, ts = 0.0, []
    for dx, dy, dz in itertools.product((0, 1), repeat=3):
        x, y, z = (min(max(i0[a] + d, 0), N - 1) for a, d in enumerate((dx, dy, dz)))
        t = tex[4 * ((z * N + y) * N + x) + c]
        ts.append(t)
        exact += (f[0] if dx else 1 - f[0]) * (f[1] if dy else 1 - f[1]) * (f[2] if dz else 1 - f[2]) * t
    return exact, ts


def main(out):
    q = floats(f'{out}/queries.f32', 'f')
    bad_total = 0
    for name in 'AB':
        tex = floats(f'{out}/tex{name}.f16', 'e')
        got = floats(f'{out}/filter{name}.f32', 'f')
        if len(tex) != N * N * N * 4 or len(got) != len(q):
            raise ValueError(f'{out}: texture {name} or its results have the wrong size')
        worst, outside, on16, n = 0.0, 0, 0, len(q) // 4
        for i in range(n):
            for c in range(4):
                exact, ts = corners(tex, q[4 * i:4 * i + 3], c)
                r = got[4 * i + c]
                spread = max(ts) - min(ts)
                e = abs(r - exact)
                if spread > 0:
                    worst = max(worst, (e - 0.5 * ulp16(exact)) / spread * 256)
                if e > 3 * WEIGHT_ERR * spread + ulp16(max(abs(t) for t in ts)):
                    outside += 1
                on16 += struct.unpack('<e', struct.pack('<e', r))[0] == r
        bad_total += outside
        print(f'texture {name}: {n} samples x 4 channels: largest error {worst:.3f}/256 of the spread; '
              f'{on16} of {4 * n} results are binary16 values; {outside} outside the model')
    return 0 if bad_total == 0 else 1


if __name__ == '__main__':
    if len(sys.argv) != 2:
        print('usage: gpu/probe/filter.py OUTDIR (what gpu/probe/probe.mjs wrote)', file=sys.stderr)
        sys.exit(2)
    try:
        sys.exit(main(sys.argv[1]))
    except (OSError, ValueError, struct.error) as e:
        print(f'filter.py: {e}', file=sys.stderr)
        sys.exit(2)
