#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora (fuzz/corpus/<target>/): small valid
inputs of every kind each parser reads, plus a few edge cases. Run from the
repo root: python3 fuzz/make_corpus.py. The output is committed; crashes
found later are added next to these as regression inputs (see README)."""
import gzip, json, os, struct, sys, zlib

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts"))
from xxh64 import xxh64  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def put(target, name, data):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def gz(b):
    return gzip.compress(b, mtime=0)


def png(w, h, depth, ctype, rows, interlace=0, palette=None):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, interlace))
    if palette:
        out += chunk(b"PLTE", palette)
    raw = b"".join(b"\x00" + r for r in rows)
    return out + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


# ---- DEM: first byte picks the file name (fuzz_dem.c's names[]) ----
NAMES = ["f.png", "f_terrarium_z9_x270_y178.png", "f_dm16.png", "f.hgt", "f.r16", "f.r32", "f_int16be.raw",
         "f.png.gz", "f.hgt.gz", "f.r16.gz", "f.r32.gz", "f_terrarium.png.gz", "f.bin"]
sel = {n: bytes([i]) for i, n in enumerate(NAMES)}
g16 = png(5, 5, 16, 0, [b"".join(struct.pack(">H", 1000 + 37 * (i + 5 * j)) for i in range(5)) for j in range(5)])
g8 = png(4, 3, 8, 0, [bytes([10 * i + j for i in range(4)]) for j in range(3)])
pal = png(3, 3, 8, 3, [bytes([0, 1, 2]), bytes([2, 1, 0]), bytes([1, 1, 1])], palette=bytes([0, 0, 0, 90, 90, 90, 200, 200, 200]))
terr = png(3, 3, 8, 2, [bytes([128, i * 10, j * 20] * 1) * 1 + bytes([128, 5, 0, 128, 6, 0]) for i, j in [(0, 0), (1, 1), (2, 2)]])
inter = png(5, 5, 16, 0, [b"".join(struct.pack(">H", 500 + i * j) for i in range(5)) for j in range(5)], interlace=1)
ga16 = png(3, 3, 16, 4, [b"".join(struct.pack(">HH", 100 * i, 65535) for i in range(3)) for _ in range(3)])
hgt = b"".join(struct.pack(">h", v) for v in [100, 120, 140, 110, -32768, 150, 90, 95, 130])
r16 = b"".join(struct.pack("<H", 1000 + 10 * k) for k in range(9))
r32 = b"".join(struct.pack("<f", v) for v in [1.5, 2.5, float("nan"), 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
r16w = b"".join(struct.pack("<H", k) for k in range(3 * 2))  # 3x2 with an explicit width byte
for name, data in [("png16", sel["f.png"] + g16), ("png8", sel["f.png"] + g8), ("palette", sel["f.png"] + pal),
                   ("terrarium", sel["f_terrarium_z9_x270_y178.png"] + terr), ("interlaced", sel["f.png"] + inter),
                   ("grey_alpha16", sel["f_dm16.png"] + ga16), ("hgt", sel["f.hgt"] + hgt), ("r16", sel["f.r16"] + r16),
                   ("r32", sel["f.r32"] + r32), ("int16be", sel["f_int16be.raw"] + hgt),
                   ("png16_gz", sel["f.png.gz"] + gz(g16)), ("hgt_gz", sel["f.hgt.gz"] + gz(hgt)),
                   ("r16_gz", sel["f.r16.gz"] + gz(r16)), ("r32_gz", sel["f.r32.gz"] + gz(r32)),
                   ("terrarium_gz", sel["f_terrarium.png.gz"] + gz(terr)), ("bin_png", sel["f.bin"] + g16),
                   ("wide_r16_gz", sel["f.r16.gz"] + gz(bytes(65537 * 2 * 2)))]:
    put("dem", name, data)

# ---- .hzt: a minimal valid tree (trunk + one branch with a leaf node) ----
def hzt(hull):
    f = lambda *v: struct.pack("<%df" % len(v), *v)
    u = lambda *v: struct.pack("<%dI" % len(v), *v)
    NONE = 0xffffffff
    bark_pos = [0, 0, 0, 0.1, 0, 0, 0, 2, 0, 0, 2, 0, 0.5, 2.5, 0, 0.5, 2.5, 0.1]
    bark_nrm = [0, 0, 1] * 6
    bark_idx = [0, 1, 2, 3, 4, 5]
    hull_pos = [0, 2, 0, 1, 2, 0, 0, 3, 0, 0, 2, 1] if hull else []
    hull_nrm = [0, 1, 0] * 4 if hull else []
    hull_idx = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3] if hull else []
    b = b"HZTREE\r\n" + u(1) + b"fuzzseed".ljust(32, b"\0") + struct.pack("<Q", 7)
    b += u(2, 2, 1, 2, 6, 6, len(hull_pos) // 3, len(hull_idx))
    b += f(0.2, 0.5, 0.1, 0.4, 0.3, 0.2) + u(0, 0, 0, 0) + struct.pack("<d", 0.0) + u(3, 6, 6, 6, 6, 6)
    b += u(NONE, 1, NONE) + f(2, 0.1, 0, 0, 0, 0, 2, 0, 0, 1, 0)
    b += u(0, 2, 0) + f(0.7, 0.05, 0, 2, 0, 0.5, 2.5, 0, 0.707, 0.707, 0)
    b += u(1, 0, 2)
    b += f(0.5, 2.5, 0, 0.1, 0, 0, 0, 0.1, 0) + f(0.6, 2.6, 0.1, 0.1, 0, 0, 0, 0, 0.1)
    b += f(*bark_pos) + f(*bark_nrm) + u(*bark_idx)
    if hull:
        b += f(*hull_pos) + f(*hull_nrm) + u(*hull_idx)
    return b + u(zlib.crc32(b) & 0xffffffff)
put("hzt", "minimal", hzt(False))
put("hzt", "minimal_hull", hzt(True))
put("hzt", "truncated", hzt(True)[:100])

# ---- camera path CSV ----
put("path", "simple", b"0,0,100,0,0,-5\n1,10,100,0,45,-5\n2,20,110,5,90,0\n")
put("path", "header", b"t,x,y,z,yaw,pitch\n0,1,2,3,4,5\n0.5,1.5,2,3,-170,5\n1,2,2,3,170,-89\n")
put("path", "comments", b"# flight\n\n  0 , 0 , 1 , 0 , 0 , 0\r\n1e-3,1e7,-1e7,0,359,90\r\n")
put("path", "bad", b"0,0,0,0,0,0\n0,1,1,1,1,1\n")

# ---- forest CSV ----
put("forest_csv", "simple", b"10,20,0,1,0\n50,60,1,1.5,90\n# c\n\n70,80,2,0.5,-45\n")
put("forest_csv", "edge", b"  -1e7,1e7,0,100,1e7\n0,0,2,1e-3,0\r\n")
put("forest_csv", "bad", b"1,2,3\n")
# Regression inputs found by the fuzzers are kept as files next to these
# (regress_*: not written here, never deleted).

# ---- view config ----
put("view_config", "simple", b"# settings\nlod-c = 30\ngenerate = perlin\nsize = 257\nwireframe = true\n")
put("view_config", "quoted", b"dem = \"../x y.png\"  # comment\nspeed='12.5'\nno-hud = off\n; ini comment\n")
put("view_config", "all", b"morph-start = 0.95\nlod = cdlod\ncamera = 1,2,3,4,5\neffects = all,-weather\n"
    b"sun = 245,30\nwind = 6.7,63\nmax-memory = 1G\nfog = off\nmouse-sens = 0.001\n")
put("view_config", "bad", b"key without value\n=3\n")

# ---- view script ----
put("view_script", "simple", b"# fly\n0 key W down\n30 key F3 press\n2s key W up\n60 look 45 -10\n61 screenshot a.png\n62 quit\n")
put("view_script", "all", b"0 button left down\n1 mouse 10 -5\n2 button left up\n3 scroll -2\n4 resize 640 480\n"
    b"5 camera 100 200 300 45 -10\n6 key SHIFT down\n7 key PAGEUP press\n1.5s key ESC press\n")
put("view_script", "bad", b"x key W down\n")

# ---- cache blobs (include/horizon/blob.h): header, then one zstd frame ----
def blob(key, data):
    import subprocess, tempfile
    with tempfile.NamedTemporaryFile() as f:
        f.write(data)
        f.flush()
        z = subprocess.run(["zstd", "-q", "-c", "--no-check", f.name], check=True, capture_output=True).stdout
    return b"HZBLOB1\n" + struct.pack("<QQQQ", key, len(data), xxh64(data), len(z)) + z


small = bytes((7 * i) & 0x0f for i in range(3000))
put("blob", "small", blob(0x1234, small))
put("blob", "tiny", blob(1, b"impostor"))
put("blob", "bad_sum", blob(0x1234, small)[:24] + b"\0" * 8 + blob(0x1234, small)[32:])

# ---- vector footprints (fuzz_footprints.c): first byte picks the format ----
FP = {"geojson": b"\x00", "csv": b"\x01", "kml": b"\x02", "gml": b"\x03"}
square = "[[8.69,49.41],[8.6902,49.41],[8.6902,49.4102],[8.69,49.4102],[8.69,49.41]]"
hole = "[[8.69005,49.41005],[8.69005,49.41010],[8.69010,49.41010],[8.69010,49.41005],[8.69005,49.41005]]"
put("footprints", "polygons.geojson", FP["geojson"] + (
    '{"type":"FeatureCollection","features":['
    '{"type":"Feature","properties":{"osm_id":1,"height":12.5},"geometry":{"type":"Polygon","coordinates":[%s]}},'
    '{"type":"Feature","properties":{"id":"b2","building:levels":"4"},"geometry":{"type":"Polygon",'
    '"coordinates":[%s,%s]}},'
    '{"type":"Feature","properties":{},"geometry":{"type":"MultiPolygon","coordinates":[[%s]]}},'
    '{"type":"Feature","properties":{"name":"a point"},"geometry":{"type":"Point","coordinates":[8.69,49.41]}}'
    ']}' % (square, square, hole, square)).encode())
put("footprints", "utm.geojson", FP["geojson"] + (
    '{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32632"}},'
    '"features":[{"type":"Feature","properties":{"height":30},"geometry":{"type":"Polygon","coordinates":'
    '[[[477000,5473000],[477020,5473000],[477010,5473015],[477000,5473000]]]}}]}').encode())
# OSM tags as GDAL's OSM driver gives them (other_tags, an hstore string), with escapes.
put("footprints", "other_tags.geojson", FP["geojson"] + json.dumps({"type": "FeatureCollection", "features": [
    {"type": "Feature", "properties": {"osm_way_id": "5", "other_tags":
        '"note"=>"a \\"height\\"=>\\"99","building:levels"=>"3","height"=>"12.5 m"'},
     "geometry": {"type": "Polygon", "coordinates": [json.loads(square)]}},
    {"type": "Feature", "properties": {"other_tags": '"height"=>"7"'},
     "geometry": {"type": "Polygon", "coordinates": [json.loads(square)]}}]}).encode())
put("footprints", "wkt.csv", FP["csv"] + (
    'WKT,height,osm_id\n"POLYGON ((8.69 49.41,8.6902 49.41,8.6902 49.4102,8.69 49.41))",9,7\n'
    '"MULTIPOLYGON (((8.69 49.41,8.6901 49.41,8.6901 49.4101,8.69 49.41)))",,8\n').encode())
put("footprints", "house.kml", FP["kml"] + (
    '<?xml version="1.0" encoding="UTF-8"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document><Placemark>'
    '<name>house</name><Polygon><outerBoundaryIs><LinearRing><coordinates>8.69,49.41 8.6902,49.41 '
    '8.6902,49.4102 8.69,49.41</coordinates></LinearRing></outerBoundaryIs></Polygon></Placemark>'
    '</Document></kml>').encode())
put("footprints", "house.gml", FP["gml"] + (
    '<?xml version="1.0" encoding="UTF-8"?><ogr:FeatureCollection xmlns:ogr="http://ogr.maptools.org/" '
    'xmlns:gml="http://www.opengis.net/gml"><gml:featureMember><ogr:b fid="b.0"><ogr:geometryProperty>'
    '<gml:Polygon srsName="EPSG:32632"><gml:outerBoundaryIs><gml:LinearRing><gml:coordinates>'
    '477000,5473000 477020,5473000 477010,5473015 477000,5473000</gml:coordinates></gml:LinearRing>'
    '</gml:outerBoundaryIs></gml:Polygon></ogr:geometryProperty><ogr:height>8</ogr:height></ogr:b>'
    '</gml:featureMember></ogr:FeatureCollection>').encode())

# ---- imagery (fuzz_imagery.c): 0 GeoTIFF; 1 PNG, 2 JPEG: then the world file's length and text ----
def geotiff(w, h, x0, y0, px, epsg, rgb):
    """A minimal uncompressed RGB GeoTIFF (little-endian, one strip): pixel
    scale, one tie point at the top-left corner, and a projected CRS key."""
    pix = bytes(rgb(x, y)[c] for y in range(h) for x in range(w) for c in range(3))
    entries = []  # (tag, type, count, payload bytes)
    def e(tag, typ, vals):
        fmt = {3: "<%dH", 4: "<%dI", 12: "<%dd"}[typ]
        entries.append((tag, typ, len(vals), struct.pack(fmt % len(vals), *vals)))
    hdr = 8
    e(256, 4, [w]); e(257, 4, [h]); e(258, 3, [8, 8, 8]); e(259, 3, [1]); e(262, 3, [2])
    e(273, 4, [0]); e(277, 3, [3]); e(278, 4, [h]); e(279, 4, [len(pix)]); e(284, 3, [1])
    e(33550, 12, [px, px, 0.0]); e(33922, 12, [0.0, 0.0, 0.0, x0, y0, 0.0])
    e(34735, 3, [1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, epsg])
    entries.sort()
    n = len(entries)
    ifd_size = 2 + 12 * n + 4
    data_at = hdr + ifd_size
    extra, ifd = b"", struct.pack("<H", n)
    strip_at = None
    for tag, typ, cnt, payload in entries:
        if len(payload) <= 4:
            ifd += struct.pack("<HHI", tag, typ, cnt) + payload.ljust(4, b"\0")
        else:
            ifd += struct.pack("<HHII", tag, typ, cnt, data_at + len(extra))
            extra += payload + (b"\0" if len(payload) % 2 else b"")
    ifd += struct.pack("<I", 0)
    strip_at = data_at + len(extra)
    out = b"II*\0" + struct.pack("<I", hdr) + ifd + extra + pix
    # patch StripOffsets (tag 273) with the strip's position
    i = out.index(struct.pack("<HHI", 273, 4, 1))
    return out[:i + 8] + struct.pack("<I", strip_at) + out[i + 12:]


colour = lambda x, y: (x * 9 % 256, y * 7 % 256, (x * y) % 256)
put("imagery", "utm.tif", b"\x00" + geotiff(32, 32, 499995.0, 5200005.0, 20.0, 32632, colour))
put("imagery", "partial.tif", b"\x00" + geotiff(16, 8, 500200.0, 5199900.0, 5.0, 32632, colour))
put("imagery", "other_zone.tif", b"\x00" + geotiff(8, 8, 300000.0, 5200000.0, 30.0, 32631, colour))
wld = b"20.0\n0.0\n0.0\n-20.0\n500005.0\n5199995.0\n"
rgbpng = png(16, 16, 8, 2, [bytes(v for x in range(16) for v in colour(x, y)) for y in range(16)])
put("imagery", "world.png", b"\x01" + bytes([len(wld)]) + wld + rgbpng)
put("imagery", "no_world.png", b"\x01\x00" + rgbpng)

# 3D models (fuzz_model): OBJ trees as tree import reads them (leaves are
# meshes named leaf/leaves/foliage/needle), also read as a scene model.
put("model", "tree.obj",
    b"# a trunk and two leaves\no trunk\nv 0 0 0\nv 0.2 0 0\nv 0.1 0 0.2\nv 0.1 3 0.1\n"
    b"f 1 2 4\nf 2 3 4\nf 3 1 4\nf 1 3 2\no leaves\nv 0.1 3 0.1\nv 0.3 3.1 0.1\nv 0.2 3.3 0.1\n"
    b"v -0.1 2.8 0.2\nv -0.3 2.9 0.2\nv -0.2 3.1 0.3\nf 5 6 7\nf 8 9 10\n")
put("model", "quads.obj",
    b"# leaves as quads, named by group and material; normals and uvs\nmtllib none.mtl\ng bark\n"
    b"v 0 0 0\nv 1 0 0\nv 1 4 0\nv 0 4 0\nvn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1 4/1/1\n"
    b"g foliage\nusemtl needle\nv 0 4 0\nv 0.5 4 0.1\nv 0.5 4.5 0.1\nv 0 4.5 0\nv 1 4 0\n"
    b"v 1.5 4 0.1\nv 1.5 4.5 0.1\nv 1 4.5 0\nf 5 6 7 8\nf 9 10 11 12\n")
