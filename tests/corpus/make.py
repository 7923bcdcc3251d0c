#!/usr/bin/env python3
"""Makes the bad-input corpus next to this file (run from the repository root after
`cargo build --release`: the KTX2 and bundle cases start from a tiny bundle the hikage binary
bakes). Every file is small and broken in one named way; index.txt says which reader reads it,
the error class it must produce and words its message must contain."""
import os, shutil, struct, subprocess, tempfile, zlib

HERE = os.path.dirname(os.path.abspath(__file__))
index = []

def put(rel, data, reader, cls, *words):
    path = os.path.join(HERE, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)
    index.append(" | ".join([reader, rel.split("/")[0] if reader == "bundle" else rel, cls, *words]))

def chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

def png(w, h, rows=None):
    ihdr = chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
    raw = b"".join(b"\0" + bytes(r) for r in (rows or [[i * 16 % 256 for i in range(w)]] * h))
    return b"\x89PNG\r\n\x1a\n" + ihdr + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")

def hair(segments, points, thickness=None, flags=None, counts=None):
    f = 2 | (1 if segments else 0) | (4 if thickness else 0)
    if flags is not None:
        f = flags
    strands, npts = counts or (len(segments), len(points))
    head = b"HAIR" + struct.pack("<IIII", strands, npts, f, 0) + struct.pack("<ffffff", 0.1, 0.5, 0.5, 0.5, 0.5, 0.0)
    head = head[:40] + b"corpus".ljust(88, b"\0")
    body = b"".join(struct.pack("<H", s) for s in segments)
    body += b"".join(struct.pack("<fff", *p) for p in points)
    body += b"".join(struct.pack("<f", t) for t in (thickness or []))
    return head + body

P5 = [(0, 0, 0), (0, 1, 0), (0, 2, 0), (1, 0, 0), (1, 1, 0)]
put("hair/counts_exceed_file.hair", hair([2, 1], P5, counts=(2, 500)), "strands", "input", "need", "the file has")
put("hair/segments_overrun.hair", hair([7, 1], P5), "strands", "input", "account for 10 points")
put("hair/nan_position.hair", hair([2, 1], [P5[0], (0, float("nan"), 0)] + P5[2:]), "strands", "input", "point 1", "finite position")
put("hair/negative_thickness.hair", hair([2, 1], P5, [0.1, 0.1, -0.5, 0.1, 0.1]), "strands", "input", "point 2", "thickness")
put("hair/four_billion_points.hair", hair([2, 1], P5, counts=(2, 4_000_000_000)), "strands", "limit", "point count")
put("hair/no_points_flag.hair", hair([2, 1], P5, flags=1), "strands", "input", "no points array")
put("hair/short_header.hair", hair([2, 1], P5)[:64], "strands", "input", "128-byte header")
put("hair/empty.hair", b"", "strands", "input", "at least one")
put("obj/index_out_of_range.obj", b"v 0 0 0\nv 1 0 0\nl 1 9\n", "strands", "input", "line 3", "out of range")
put("obj/single_index.obj", b"v 0 0 0\nl 1\n", "strands", "input", "line 2", "two or more")
put("obj/nan_vertex.obj", b"v 0 nan 0\nv 1 0 0\nl 1 2\n", "strands", "input", "line 1", "finite")

def glb(json_text, bin_bytes=b""):
    j = json_text.encode().ljust((len(json_text) + 3) // 4 * 4, b" ")
    b = bin_bytes.ljust((len(bin_bytes) + 3) // 4 * 4, b"\0")
    chunks = struct.pack("<I", len(j)) + b"JSON" + j + (struct.pack("<I", len(b)) + b"BIN\0" + b if b else b"")
    return b"glTF" + struct.pack("<II", 2, 12 + len(chunks)) + chunks

TRI = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<6f", 0, 0, 1, 0, 0, 1)
def tri_json(attributes='"POSITION": 0, "TEXCOORD_0": 1', uri="", count=3):
    return ('{"asset": {"version": "2.0"}, "buffers": [{%s"byteLength": 60}], '
            '"bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24}], '
            '"accessors": [{"bufferView": 0, "componentType": 5126, "count": %d, "type": "VEC3"}, '
            '{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}], '
            '"meshes": [{"primitives": [{"attributes": {%s}}]}]}') % (uri, count, attributes)
put("gltf/truncated.glb", glb(tri_json(), TRI)[:-20], "mesh", "input", "GLB header says", "the file has")
put("gltf/no_uv.glb", glb(tri_json('"POSITION": 0'), TRI), "mesh", "input", "primitive 0", "TEXCOORD_0")
put("gltf/count_past_view.glb", glb(tri_json(count=4000000000), TRI), "mesh", "input", "accessor 0", "do not fit")
put("gltf/escaping_uri.gltf", tri_json(uri='"uri": "../../etc/passwd", ').encode(), "mesh", "input", "buffer 0", "beside the glTF")
put("gltf/not_json.gltf", b"{ nope", "mesh", "input", "glTF JSON")

put("png/truncated.png", png(8, 8)[:60], "heightfield", "input", "PNG")
put("png/huge_header.png", png(8, 8)[:33].replace(struct.pack(">II", 8, 8), struct.pack(">II", 100000, 100000)), "heightfield", "limit", "100000")
put("png/empty.png", b"", "heightfield", "input", "0-byte")
put("png/not_an_image.png", b"this is text, not a picture\n", "heightfield", "input", "signature")
put("png/zero_width.png", png(8, 8)[:33].replace(struct.pack(">II", 8, 8), struct.pack(">II", 0, 8)), "heightfield", "input", "non-empty")
exr = open("data/dunes.exr", "rb").read()
put("exr/truncated.exr", exr[:400], "heightfield", "input", "OpenEXR")

put("pipeline/typo.ron", b'(output: "b", jobs: [Relief(id: "x", input: "x.png", thta: 4)])', "pipeline", "pipeline", "thta")
put("pipeline/bad_setting.ron", b'(output: "b", jobs: [Relief(id: "x", input: "x.png", theta: 0)])', "pipeline", "setting", "theta")
put("pipeline/bad_id.ron", b'(output: "b", jobs: [Strands(id: "../x", input: "h.hair")])', "pipeline", "setting", "id")
put("pipeline/not_ron.ron", b"\xff\xfe not text", "pipeline", "pipeline", "")

# A tiny real bundle to break: a 4x4 heightfield.
tmp = tempfile.mkdtemp()
with open(os.path.join(tmp, "t.png"), "wb") as f:
    f.write(png(4, 4, [[0, 60, 120, 180]] * 4))
with open(os.path.join(tmp, "pipeline.ron"), "w") as f:
    f.write('(output: "b", jobs: [Heightfield(id: "t", input: "t.png", format: R16Float)])')
subprocess.run([os.path.abspath("target/release/hikage"), "bake", os.path.join(tmp, "pipeline.ron")], check=True, stdout=subprocess.DEVNULL)
bdir = os.path.join(tmp, "b")
manifest = open(os.path.join(bdir, "bundle.ron")).read()
payload_name = [n for n in os.listdir(bdir) if n.endswith(".ktx2")][0]
ktx = open(os.path.join(bdir, payload_name), "rb").read()

big = bytearray(ktx)
big[80 + 8:80 + 16] = struct.pack("<Q", 1 << 40)      # level 0 byteLength
big[80 + 16:80 + 24] = struct.pack("<Q", 1 << 40)     # level 0 uncompressedByteLength
put("ktx2/level_of_2e40_bytes.ktx2", bytes(big), "ktx2", "ktx2", "level 0 claims 1099511627776")
put("ktx2/truncated.ktx2", ktx[:70], "ktx2", "ktx2", "80-byte header")
wrong = bytearray(ktx)
wrong[12:16] = struct.pack("<I", 999)                  # vkFormat
put("ktx2/unknown_format.ktx2", bytes(wrong), "ktx2", "ktx2", "999")
put("ktx2/not_ktx2.ktx2", b"\xabKTX 10\xbb\r\n\x1a\n" + b"\0" * 80, "ktx2", "ktx2", "")

def bundle(name, text, payload=ktx, cls="invalid_asset", *words):
    d = os.path.join(HERE, name)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    with open(os.path.join(d, "bundle.ron"), "w") as f:
        f.write(text)
    if payload is not None:
        with open(os.path.join(d, payload_name), "wb") as f:
            f.write(payload)
    index.append(" | ".join(["bundle", name, cls, *words]))

bundle("bundle_escaping_path", manifest.replace(payload_name, "../" + payload_name), ktx, "invalid_asset", "not a plain file name")
entry = manifest.split("assets: [", 1)[1].rsplit("]", 1)[0].rstrip()  # "(...)," of the one asset
bundle("bundle_duplicate_ids", manifest.replace("assets: [", "assets: [" + entry, 1), ktx, "invalid_asset", "duplicate")
bundle("bundle_syntax_error", manifest.replace("kind:", "kind"), ktx, "manifest_syntax", "")
bundle("bundle_unknown_major", manifest.replace("major: 1", "major: 9"), ktx, "unsupported_version", "9.")
flipped = bytearray(ktx)
flipped[-1] ^= 1
bundle("bundle_hash_mismatch", manifest, bytes(flipped), "payload", "BLAKE3")
bundle("bundle_missing_payload", manifest, None, "io", "")
bundle("bundle_empty_manifest", "", None, "manifest_syntax", "")
shutil.rmtree(tmp)

with open(os.path.join(HERE, "index.txt"), "w") as f:
    f.write("# reader | file or directory | error class | words the message contains\n")
    f.write("\n".join(index) + "\n")
print(len(index), "cases")
