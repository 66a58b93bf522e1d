#!/usr/bin/env python3
"""Seed corpus for the glTF fuzz target (tests/fuzz_gltf.c): usage gltf_corpus.py OUTDIR FIXTURES [MORE_DIRS...]

The fuzz target loads with embedded_only, so a seed that names an external file is refused before its accessors,
nodes and textures are ever looked at. For every .gltf / .glb found, this writes:
  - the file as it is (exercises the JSON and schema passes);
  - for a .gltf whose buffers are small enough: a self-contained .gltf (buffers as data: URIs) and a .glb (buffer 0
    in the BIN chunk, any others as data: URIs), with every image replaced by a 2x2 PNG data: URI, so seeds stay small
    and still reach the texture path.
The two smallest JPEGs found under the directories become textured one-triangle seeds. Seeds larger than MAX_SEED bytes
are left out (large inputs slow every mutation down)."""
import base64
import json
import os
import struct
import sys
import zlib

MAX_SEED = 256 * 1024


def png_2x2():
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    raw = b"".join(b"\0" + bytes([255, 0, 0, 255, 0, 255, 0, 128]) for _ in range(2))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def data_uri(mime, data):
    return "data:%s;base64,%s" % (mime, base64.b64encode(data).decode())


def inline(path):
    """(self-contained .gltf text, .glb bytes) of the .gltf at path, or None when it cannot be inlined."""
    with open(path, "rb") as f:
        doc = json.loads(f.read())
    base = os.path.dirname(path)
    blobs = []
    for b in doc.get("buffers", []):
        uri = b.get("uri", "")
        if uri.startswith("data:"):
            blobs.append(base64.b64decode(uri.split(",", 1)[1]))
            continue
        p = os.path.join(base, uri)
        if not uri or not os.path.isfile(p) or os.path.getsize(p) > MAX_SEED:
            return None
        with open(p, "rb") as f:
            blobs.append(f.read()[: b.get("byteLength", 0)])
    tiny = png_2x2()
    for img in doc.get("images", []):
        if "uri" in img:
            img["uri"] = data_uri("image/png", tiny)
    text_doc = json.loads(json.dumps(doc))
    for b, blob in zip(text_doc.get("buffers", []), blobs):
        b["uri"] = data_uri("application/octet-stream", blob)
    text = json.dumps(text_doc, separators=(",", ":")).encode()
    bin_chunk = b""
    if blobs:
        for i, (b, blob) in enumerate(zip(doc["buffers"], blobs)):
            if i == 0:
                b.pop("uri", None)
                bin_chunk = blob + b"\0" * (-len(blob) % 4)
            else:
                b["uri"] = data_uri("application/octet-stream", blob)
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js
    if bin_chunk:
        body += struct.pack("<I4s", len(bin_chunk), b"BIN\0") + bin_chunk
    glb = struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body
    return text, glb


def textured_triangle(mime, image):
    """A one-triangle .gltf whose material's base colour is the given image, as a data: URI."""
    tri = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    doc = {"asset": {"version": "2.0"},
           "buffers": [{"byteLength": len(tri), "uri": data_uri("application/octet-stream", tri)}],
           "bufferViews": [{"buffer": 0, "byteLength": len(tri)}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
           "images": [{"uri": data_uri(mime, image)}], "textures": [{"source": 0}],
           "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}], "nodes": [{"mesh": 0}]}
    return json.dumps(doc, separators=(",", ":")).encode()


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: gltf_corpus.py OUTDIR FIXTURES [MORE_DIRS...]")
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    written = 0

    def put(name, data):
        nonlocal written
        if len(data) <= MAX_SEED:
            with open(os.path.join(out, name), "wb") as f:
                f.write(data)
            written += 1

    jpegs = []
    for root_dir in sys.argv[2:]:
        if not os.path.isdir(root_dir):
            continue
        for root, _, files in sorted(os.walk(root_dir)):
            for name in sorted(files):
                low = name.lower()
                path = os.path.join(root, name)
                if low.endswith(".jpg") and os.path.getsize(path) <= 16 * 1024:
                    jpegs.append((os.path.getsize(path), path))
                if not (low.endswith(".gltf") or low.endswith(".glb")):
                    continue
                path = os.path.join(root, name)
                stem = os.path.relpath(path, root_dir).replace(os.sep, "_")
                with open(path, "rb") as f:
                    put(stem, f.read())
                if low.endswith(".gltf"):
                    try:
                        made = inline(path)
                    except (ValueError, KeyError, TypeError, AttributeError, OSError):  # glTF 1.0, broken JSON
                        made = None
                    if made:
                        put(stem + ".embedded.gltf", made[0])
                        put(stem + ".glb", made[1])
    # JPEG is the other texture format glTF allows; the inlined seeds above carry PNGs only.
    for i, (_, path) in enumerate(sorted(jpegs)[:2]):
        with open(path, "rb") as f:
            put("jpeg_texture_%d.gltf" % i, textured_triangle("image/jpeg", f.read()))
    put("png_texture.gltf", textured_triangle("image/png", png_2x2()))
    print("%d seeds in %s" % (written, out))


if __name__ == "__main__":
    main()
