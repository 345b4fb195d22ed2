#!/usr/bin/env python3
"""Draped imagery (--imagery), through the horizon program as a user runs it:
a red marker drawn into an orthophoto at a known lon/lat must land, in the
rendered frame, within one DEM sample of that lon/lat (found with --pick,
the CPU picking, independent of the shader). Three georeferences: a GeoTIFF
in EPSG:4326 over a DEM the loader reprojects to UTM, a PNG with a world
file and no CRS, and a fine image that is cut into tiles. Bad inputs are
refused with a message and a non-zero exit.

usage: test_imagery.py HORIZON DATA TMPDIR"""
import json, math, os, struct, subprocess, sys, zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pngstat  # noqa: E402
from clitest import ok, bad, check, run_hz, finish  # noqa: E402,F401

HZ, DATA, TMP = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(TMP, exist_ok=True)
def tmp(name):
    return os.path.join(TMP, name)


def sh(args):
    p = subprocess.run(args, capture_output=True, timeout=300)
    if p.returncode != 0:
        print("FAIL " + " ".join(args) + ": " + p.stderr.decode("utf-8", "replace"))
        sys.exit(1)
    return p.stdout.decode()


def run(args, timeout=300):
    return run_hz(HZ, args, timeout)


def render_json(args):
    rc, out, err = run(["render", "--quiet", "--json", "--effects", "none"] + args)
    if rc != 0:
        return None, err
    try:
        return json.loads(out), err
    except ValueError as e:
        return None, "bad JSON: %s: %s" % (e, out[:300])


def write_png(path, w, h, pixel):
    """An 8-bit RGB PNG; pixel(x, y) -> (r, g, b)."""
    raw = bytearray()
    for y in range(h):
        raw.append(0)
        for x in range(w):
            raw.extend(pixel(x, y))

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(bytes(raw), 6)) + chunk(b"IEND", b""))


def marker_image(path, w, h, mx, my, half=2):
    """Grey, with a red square of 2 half + 1 pixels centred on pixel (mx, my)."""
    def px(x, y):
        if abs(x - mx) <= half and abs(y - my) <= half:
            return (230, 20, 20)
        return (120, 124, 118)
    write_png(path, w, h, px)


def to_utm(lon, lat):
    p = subprocess.run(["gdaltransform", "-s_srs", "EPSG:4326", "-t_srs", "EPSG:32632"], input=b"%.9f %.9f\n" % (lon, lat),
                       capture_output=True, timeout=60)
    e, n = p.stdout.split()[:2]
    return float(e), float(n)


def metres(lon1, lat1, lon2, lat2):
    """Great-circle distance (spherical Earth): enough at these scales."""
    r = 6371008.8
    p1, p2 = math.radians(lat1), math.radians(lat2)
    a = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(math.radians(lon2 - lon1) / 2) ** 2
    return 2 * r * math.asin(math.sqrt(a))


def red_centroid(png):
    w, h, rows = pngstat.read(png)
    sx = sy = n = 0
    for y, row in enumerate(rows):
        for x, (r, g, b) in enumerate(row):
            if r > 100 and r > g + 60 and r > b + 60:  # red through the haze
                sx, sy, n = sx + x, sy + y, n + 1
    return (sx / n + 0.5, sy / n + 0.5, n) if n else (0, 0, 0)


# A DEM: a 0.2 x 0.2 degree cut of the SRTM GeoTIFF (EPSG:4326, reprojected
# by the loader to UTM 32N at about 64 m).
DEM = tmp("dem.tif")
sh(["gdal_translate", "-q", "-srcwin", "500", "500", "240", "240", os.path.join(DATA, "N46E008.tif"), DEM])
W, H = 640, 360
base, err = render_json(["--dem", DEM, "--width", str(W), "--height", str(H), "--out", tmp("base.png")])
check(base and base.get("crs") == "EPSG:32632", "the DEM is georeferenced (UTM 32N)", err)
if not base:
    sys.exit(1)
SPACING = base["spacing"]
OX, OY = base["origin_crs"]  # CRS position of local (0, 0)


def lands(name, image, lon, lat, extra=(), camera_h=9000.0):
    """Renders straight down over (lon, lat) with the image draped, finds the
    red marker and picks it: it must lie within one sample of (lon, lat)."""
    e, n = to_utm(lon, lat)
    x, z = e - OX, OY - n
    out = tmp(name + ".png")
    cam = "%.2f,%.1f,%.2f,0,-90" % (x, camera_h, z)
    args = ["--dem", DEM, "--imagery", image, "--width", str(W), "--height", str(H), "--camera", cam, "--out", out]
    j, err = render_json(list(args) + list(extra))
    check(j and "imagery" in j and j["imagery"]["coverage"] > 0.01, name + ": rendered, imagery reported", j or err)
    if not j:
        return None
    cx, cy, npx = red_centroid(out)
    check(npx > 0, name + ": the marker is visible in the frame", out)
    if not npx:
        return j
    jp, err = render_json(list(args) + list(extra) + ["--pick", "%.2f,%.2f" % (cx, cy)])
    pk = jp and jp.get("pick")
    check(pk and pk.get("hit") and pk.get("lonlat"), name + ": --pick hits the terrain under the marker", jp or err)
    if pk and pk.get("lonlat"):
        d = metres(pk["lonlat"][0], pk["lonlat"][1], lon, lat)
        check(d <= SPACING, "%s: the marker lands %.1f m from its lon/lat (one sample is %.1f m)" % (name, d, SPACING),
              pk)
    return j


# 1. A GeoTIFF in EPSG:4326 (the DEM is drawn in UTM): 0.0002 degree pixels.
RES, LON0, LAT0 = 0.0002, 8.40, 46.60
MX, MY = 500, 500
marker_image(tmp("geo.png"), 1200, 1150, MX, MY)
GEO = tmp("geo.tif")
sh(["gdal_translate", "-q", "-a_srs", "EPSG:4326", "-a_ullr", str(LON0), str(LAT0), str(LON0 + 1200 * RES),
    str(LAT0 - 1150 * RES), tmp("geo.png"), GEO])
MLON, MLAT = LON0 + (MX + 0.5) * RES, LAT0 - (MY + 0.5) * RES
j = lands("geotiff_4326", GEO, MLON, MLAT)
if j:
    check(j["imagery"]["tiles_per_side"] == 0 and 10 < j["imagery"]["image_metres_per_pixel"] < 25,
          "geotiff_4326: one texture at the image's own resolution (15 x 22 m pixels)", j["imagery"])
# Without --imagery there is no red there: the marker comes from the image.
if base:
    check(red_centroid(tmp("base.png"))[2] == 0, "without --imagery the frame has no red marker")

# 2. A PNG with a world file (.pgw) and no CRS: taken to be the terrain's (UTM 32N), said on stderr.
lon2, lat2 = 8.53, 46.45
e2, n2 = to_utm(lon2, lat2)
PX = 20.0
ulx, uly = e2 - 400.5 * PX, n2 + 300.5 * PX  # centre of the upper-left pixel; the marker at pixel (400, 300)
marker_image(tmp("wf.png"), 800, 600, 400, 300)
with open(tmp("wf.pgw"), "w") as f:
    f.write("%.6f\n0\n0\n%.6f\n%.6f\n%.6f\n" % (PX, -PX, ulx + 0.5 * PX, uly - 0.5 * PX))
lands("world_file", tmp("wf.png"), lon2, lat2)
rc, out, err = run(["render", "--dem", DEM, "--imagery", tmp("wf.png"), "--effects", "none", "--width", "160",
                    "--height", "90", "--out", tmp("wf_note.png")])
check(rc == 0 and "has no CRS" in err and "EPSG:32632" in err, "a world file without CRS: the assumption is said", err)

# 3. A fine image (2.5 m pixels) cut into tiles: the marker still lands, and tiles are used.
FINE = tmp("fine.tif")
sh(["gdalwarp", "-q", "-overwrite", "-r", "near", "-tr", "0.000025", "0.000025", "-te", "8.45", "46.45", "8.55", "46.55", GEO, FINE])
j = lands("tiled", FINE, MLON, MLAT, extra=["--imagery-max", "8192"], camera_h=5000.0)
if j:
    check(j["imagery"]["tiles_per_side"] >= 2 and j["imagery"]["texels_per_side"] > 4096,
          "tiled: the image is cut into tiles (%s per side)" % j["imagery"]["tiles_per_side"], j["imagery"])
# --imagery-max caps the texels: the same image as one texture.
j, err = render_json(["--dem", DEM, "--imagery", FINE, "--imagery-max", "2048", "--width", "160", "--height", "90",
                      "--out", tmp("capped.png")])
check(j and j["imagery"]["texels_per_side"] == 2048 and j["imagery"]["tiles_per_side"] == 0,
      "--imagery-max 2048 caps the texels per side", j and j["imagery"] or err)


# 4. A streamed pyramid of the same DEM: the marker is drawn at the same pixel
# (within one sample) as on the in-memory terrain, with the same camera.
HZP = tmp("dem.hzp")
rc, out, err = run(["import", DEM, "--out", HZP, "--quiet"])
check(rc == 0, "the DEM imports to a pyramid", err)
e, n = to_utm(MLON, MLAT)
cam = "%.2f,9000,%.2f,0,-90" % (e - OX, OY - n)
rc, out, err = run(["render", "--terrain", HZP, "--imagery", GEO, "--width", str(W), "--height", str(H), "--camera",
                    cam, "--out", tmp("streamed.png"), "--quiet"])
check(rc == 0, "render --terrain X.hzp --imagery", err)
if rc == 0 and os.path.exists(tmp("geotiff_4326.png")):
    sx, sy, sn = red_centroid(tmp("streamed.png"))
    mx, my, mn = red_centroid(tmp("geotiff_4326.png"))
    px_per_sample = H / (2 * math.tan(math.radians(30)) * (9000 - 1400)) * SPACING  # ground ~1400 m
    check(sn > 0 and mn > 0 and math.hypot(sx - mx, sy - my) <= px_per_sample,
          "streamed: the marker is %.1f px from the in-memory one (one sample ~%.1f px)" %
          (math.hypot(sx - mx, sy - my), px_per_sample), (sx, sy, sn, mx, my, mn))


# 5. Bad input: a message and a non-zero exit, never a crash.
def refused(name, args, needle):
    rc, out, err = run(["render", "--effects", "none", "--width", "160", "--height", "90", "--out",
                        tmp("refused.png")] + args)
    check(rc not in (0, -11, -6) and rc > 0 and needle in err, name + " is refused (%s)" % needle, (rc, err))


write_png(tmp("plain.png"), 64, 64, lambda x, y: (10, 200, 10))
refused("an image without georeference", ["--dem", DEM, "--imagery", tmp("plain.png")], "no georeference")
refused("a missing image", ["--dem", DEM, "--imagery", tmp("missing.tif")], "missing.tif")
refused("a folder", ["--dem", DEM, "--imagery", TMP], "folder")
refused("a generated terrain (no georeference)", ["--generate", "perlin", "--size", "129", "--imagery", GEO],
        "no georeference")
sh(["gdal_translate", "-q", "-ot", "UInt16", GEO, tmp("u16.tif")])
refused("a 16-bit image", ["--dem", DEM, "--imagery", tmp("u16.tif")], "8-bit")
sh(["gdal_translate", "-q", "-a_ullr", "20", "10", "20.2", "9.8", GEO, tmp("far.tif")])
refused("an image elsewhere on Earth", ["--dem", DEM, "--imagery", tmp("far.tif")], "does not overlap")
with open(tmp("trunc.tif"), "wb") as f:
    f.write(open(GEO, "rb").read()[:5000])
refused("a truncated GeoTIFF", ["--dem", DEM, "--imagery", tmp("trunc.tif")], "imagery")
refused("--imagery-max 10", ["--dem", DEM, "--imagery", GEO, "--imagery-max", "10"], "--imagery-max")
refused("a budget too small", ["--dem", DEM, "--imagery", FINE, "--imagery-max", "8192", "--max-memory", "200M"],
        "budget")

finish()
