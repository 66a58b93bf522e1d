#!/usr/bin/env python3
"""Test images made without rtoracle (Python standard library only), and a PNG pixel reader, for cli.compare.

  images.py make OUT.png|OUT.exr PATTERN [W H C]   writes the image (PNG: 8-bit; OpenEXR: float, uncompressed)
  images.py set DIR                                  writes cli.compare's images (one Python start, not twelve)
  images.py pixel FILE.png X Y [X Y ...]             prints the channel values of each pixel (X, Y), one a line
  images.py truncate IN OUT N                        writes the first N bytes of IN to OUT

Patterns, all derived from one base image so that each differs from it in one known way:
  base      v(x, y, c) = ((37 x + 91 y + 53 c + 11) mod 256) / 255
  shift     base shifted right by one pixel (column 0 repeats)
  swap-rb   base with channels 0 and 2 exchanged
  invert-g  base with channel 1 replaced by 1 - v
  gamma     base with every colour channel raised to 1 / 2.2 (alpha untouched)
  noise     base with 1/255 added to channel 0 of every 7th pixel (row-major), 254 -> 255 capped
  one-off   base with channel 2 of pixel (3, 2) raised by 5/255 (wrapping within 0 .. 255)
  bright    base 1 % brighter: every colour channel times 1.01, rounded, capped at 255 (alpha untouched)
"""
import struct
import sys
import zlib


def base(w, h, c):
    return [[[((37 * x + 91 * y + 53 * k + 11) % 256) for k in range(c)] for x in range(w)] for y in range(h)]


def pattern(name, w, h, c):
    img = base(w, h, c)
    if name == "base":
        pass
    elif name == "shift":
        img = [[row[max(x - 1, 0)][:] for x in range(w)] for row in img]
    elif name == "swap-rb":
        for row in img:
            for p in row:
                p[0], p[2] = p[2], p[0]
    elif name == "invert-g":
        for row in img:
            for p in row:
                p[1] = 255 - p[1]
    elif name == "gamma":
        colour = 3 if c >= 3 else 1
        for row in img:
            for p in row:
                for k in range(colour):
                    p[k] = round(255 * (p[k] / 255) ** (1 / 2.2))
    elif name == "noise":
        for y, row in enumerate(img):
            for x, p in enumerate(row):
                if (y * w + x) % 7 == 0:
                    p[0] = min(p[0] + 1, 255)
    elif name == "one-off":
        img[2][3][2] = (img[2][3][2] + 5) % 256
    elif name == "bright":
        colour = 3 if c >= 3 else 1
        for row in img:
            for p in row:
                for k in range(colour):
                    p[k] = min(255, round(p[k] * 1.01))
    else:
        raise SystemExit("unknown pattern " + name)
    return img


def png_chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def write_png(path, img, c):
    h, w = len(img), len(img[0])
    colour_type = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    raw = b"".join(b"\0" + bytes(v for p in row for v in p) for row in img)
    data = b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
    data += png_chunk(b"IDAT", zlib.compress(raw)) + png_chunk(b"IEND", b"")
    open(path, "wb").write(data)


def exr_attr(name, kind, value):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def write_exr(path, img, c):
    """A single-part scanline OpenEXR file, compression NONE, FLOAT channels (OpenEXR file layout document)."""
    h, w = len(img), len(img[0])
    names = {1: ["Y"], 2: ["A", "Y"], 3: ["B", "G", "R"], 4: ["A", "B", "G", "R"]}[c]
    order = {1: ["Y"], 2: ["Y", "A"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}[c]
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for n in names) + b"\0"
    header = b"\x76\x2f\x31\x01" + struct.pack("<I", 2)
    header += exr_attr("channels", "chlist", chlist)
    header += exr_attr("compression", "compression", b"\0")
    header += exr_attr("dataWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1))
    header += exr_attr("displayWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1))
    header += exr_attr("lineOrder", "lineOrder", b"\0")
    header += exr_attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    header += exr_attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
    header += exr_attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    header += b"\0"
    # Each scanline: y, byte count, then each channel's row (channels in name order).
    lines = []
    for y, row in enumerate(img):
        body = b"".join(struct.pack("<%df" % w, *[p[order.index(n)] / 255 for p in row]) for n in names)
        lines.append(struct.pack("<ii", y, len(body)) + body)
    offset = len(header) + 8 * h
    table = b""
    for line in lines:
        table += struct.pack("<Q", offset)
        offset += len(line)
    open(path, "wb").write(header + table + b"".join(lines))


def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    at, idat, ihdr = 8, b"", None
    while at < len(data):
        n = struct.unpack(">I", data[at:at + 4])[0]
        kind, body = data[at + 4:at + 8], data[at + 8:at + 8 + n]
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        at += 12 + n
    w, h, depth, colour_type, _, _, interlace = ihdr
    assert depth == 8 and interlace == 0, "only 8-bit, non-interlaced PNG"
    c = {0: 1, 4: 2, 2: 3, 6: 4}[colour_type]
    raw, stride, rows, prev = zlib.decompress(idat), w * c, [], bytearray(w * c)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):  # PNG spec §9: filter types 0-4
            a = line[i - c] if i >= c else 0
            b, cc = prev[i], prev[i - c] if i >= c else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - cc
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else cc)) & 255
        rows.append(line)
        prev = line
    return w, h, c, rows


def main(argv):
    if argv[1] == "make":
        out, name = argv[2], argv[3]
        w, h, c = (int(v) for v in argv[4:7]) if len(argv) > 4 else (16, 12, 4)
        img = pattern(name, w, h, c)
        (write_exr if out.endswith(".exr") else write_png)(out, img, c)
    elif argv[1] == "set":
        for name in ["base", "shift", "swap-rb", "invert-g", "gamma", "noise", "one-off", "bright"]:
            write_png("%s/%s.png" % (argv[2], name), pattern(name, 16, 12, 4), 4)
        for name in ["base", "one-off"]:
            write_exr("%s/%s.exr" % (argv[2], name), pattern(name, 16, 12, 4), 4)
        for name in ["base", "noise", "bright", "shift"]:  # RGB: no alpha for idiff to premultiply by
            write_png("%s/%s3.png" % (argv[2], name), pattern(name, 16, 12, 3), 3)
        write_png(argv[2] + "/wide.png", pattern("base", 17, 12, 4), 4)
        data = open(argv[2] + "/base.png", "rb").read()
        open(argv[2] + "/cut.png", "wb").write(data[:100])
        data = open(argv[2] + "/base.exr", "rb").read()
        open(argv[2] + "/cut.exr", "wb").write(data[:400])
    elif argv[1] == "pixel":
        w, h, c, rows = read_png(argv[2])
        for i in range(3, len(argv), 2):
            x, y = int(argv[i]), int(argv[i + 1])
            print(" ".join(str(v) for v in rows[y][x * c:(x + 1) * c]))
    elif argv[1] == "truncate":
        open(argv[3], "wb").write(open(argv[2], "rb").read()[:int(argv[4])])
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
