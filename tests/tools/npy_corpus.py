#!/usr/bin/env python3
"""Seed corpus for the .npy fuzz target (tests/fuzz_npy.c): usage npy_corpus.py OUTDIR

Small valid files of every kind the reader takes (the dtypes of keys, rays, hits, images and counters; 1 to 3
dimensions, an empty array, format versions 1.0 and 2.0, a structured dtype) and a few it must refuse (Fortran order,
big-endian, a header cut short), so mutations start near both sides of the reader's rules."""
import os
import struct
import sys


def npy(descr, shape, data, version=(1, 0), fortran=False):
    shape_text = "(" + ", ".join(str(d) for d in shape) + ("," if len(shape) == 1 else "") + ")"
    header = f"{{'descr': {descr}, 'fortran_order': {fortran}, 'shape': {shape_text}, }}"
    size_field = "<H" if version[0] == 1 else "<I"
    prefix = 10 if version[0] == 1 else 12
    pad = -(prefix + len(header) + 1) % 64
    header = header + " " * pad + "\n"
    return (b"\x93NUMPY" + bytes(version) + struct.pack(size_field, len(header)) + header.encode("latin1") + data)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    ray = "[('origin', '<f4', (3,)), ('tmin', '<f4'), ('dir', '<f4', (3,)), ('tmax', '<f4')]"
    seeds = {
        "u32.npy": npy("'<u4'", (5,), struct.pack("<5I", 1, 2, 3, 0xFFFFFFFF, 0)),
        "u64.npy": npy("'<u8'", (3,), struct.pack("<3Q", 1, 2**63, 7)),
        "f32-2d.npy": npy("'<f4'", (2, 3), struct.pack("<6f", 0, 1, -1, 0.5, 1e30, -0.0)),
        "f32-3d.npy": npy("'<f4'", (1, 2, 4), struct.pack("<8f", *range(8))),
        "u8-2d.npy": npy("'|u1'", (2, 2), bytes([0, 1, 2, 255])),
        "empty.npy": npy("'<u4'", (0,), b""),
        "v2.npy": npy("'<u4'", (2,), struct.pack("<2I", 9, 8), version=(2, 0)),
        "rays.npy": npy(ray, (1,), struct.pack("<8f", 0, 0, 0, 0, 0, 0, 1, 1e30)),
        "fortran.npy": npy("'<f4'", (2, 2), struct.pack("<4f", 1, 2, 3, 4), fortran=True),
        "big-endian.npy": npy("'>u4'", (1,), struct.pack(">I", 1)),
        "cut.npy": npy("'<u4'", (4,), struct.pack("<2I", 1, 2)),
    }
    for name, data in seeds.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    main()
