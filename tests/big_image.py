#!/usr/bin/env python3
"""big_image.py OUT.png|OUT.exr WIDTH HEIGHT: an image whose header claims WIDTH x HEIGHT (RGBA, 8-bit for PNG,
float for EXR) but whose pixel data is a stub of a few bytes. Decoded, it would take gigabytes (and fail); a reader
that checks the header's size before decoding refuses it at once."""
import struct
import sys
import zlib


def png(width, height):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) +
            chunk(b"IEND", b""))


def exr(width, height):
    # OpenEXR 2.0 single-part scan-line file, uncompressed (one line per chunk); its offset table points every line
    # at one stub chunk.
    def attr(name, kind, value):
        return name + b"\0" + kind + b"\0" + struct.pack("<i", len(value)) + value
    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"A", b"B", b"G", b"R")) + b"\0"
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (struct.pack("<ii", 20000630, 2) + attr(b"channels", b"chlist", channels) +
              attr(b"compression", b"compression", b"\0") + attr(b"dataWindow", b"box2i", window) +
              attr(b"displayWindow", b"box2i", window) + attr(b"lineOrder", b"lineOrder", b"\0") +
              attr(b"pixelAspectRatio", b"float", struct.pack("<f", 1)) +
              attr(b"screenWindowCenter", b"v2f", struct.pack("<ff", 0, 0)) +
              attr(b"screenWindowWidth", b"float", struct.pack("<f", 1)) + b"\0")
    stub = len(header) + 8 * height
    return header + struct.pack("<Q", stub) * height + struct.pack("<ii", 0, 16) + b"\0" * 16


def main():
    out, width, height = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    data = exr(width, height) if out.endswith(".exr") else png(width, height)
    with open(out, "wb") as f:
        f.write(data)


if __name__ == "__main__":
    main()
