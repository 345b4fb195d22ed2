"""A small PNG reader for the tests (8-bit RGB/RGBA/grey, non-interlaced,
which is what horizon writes) and image figures: mean colour, mean hue of
the coloured pixels, the share of distinct colours."""
import colorsys, struct, zlib


def read(path):
    """(width, height, rows): rows[y] is a list of (r, g, b) tuples."""
    d = open(path, "rb").read()
    if d[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG: " + path)
    i, idat = 8, b""
    while i < len(d):
        n = struct.unpack(">I", d[i:i + 4])[0]
        t = d[i + 4:i + 8]
        if t == b"IHDR":
            w, h, bd, ct, _, _, il = struct.unpack(">IIBBBBB", d[i + 8:i + 21])
        elif t == b"IDAT":
            idat += d[i + 8:i + 8 + n]
        i += 12 + n
    if bd != 8 or il or ct not in (0, 2, 4, 6):
        raise ValueError("unsupported PNG layout in " + path)
    ch = {0: 1, 2: 3, 4: 2, 6: 4}[ct]
    raw = zlib.decompress(idat)
    stride = w * ch
    prev = bytearray(stride)
    rows = []
    p = 0
    for _ in range(h):
        f = raw[p]
        line = bytearray(raw[p + 1:p + 1 + stride])
        p += 1 + stride
        for x in range(stride):
            a = line[x - ch] if x >= ch else 0
            b = prev[x]
            c = prev[x - ch] if x >= ch else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + ((a + b) >> 1)) & 255
            elif f == 4:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pr) & 255
        prev = line
        if ch >= 3:
            rows.append([(line[k], line[k + 1], line[k + 2]) for k in range(0, stride, ch)])
        else:
            rows.append([(line[k], line[k], line[k]) for k in range(0, stride, ch)])
    return w, h, rows


def pixels(path, y0=0.0, y1=1.0):
    """The pixels of the rows between the fractions y0 and y1 of the height."""
    w, h, rows = read(path)
    out = []
    for row in rows[int(y0 * h):int(y1 * h)]:
        out.extend(row)
    return out


def is_sky(p):
    """The renderer's sky: blue well above red (see tests/view/view_png.c)."""
    r, g, b = p
    return b > r + 40 and b > 120


def mean_hue(px):
    """Mean hue in degrees (circular mean, weighted by saturation) of px, and
    the share of green pixels (hue 70..170 with some saturation)."""
    import math
    sx = sy = wsum = 0.0
    green = 0
    for r, g, b in px:
        hh, s, v = colorsys.rgb_to_hsv(r / 255.0, g / 255.0, b / 255.0)
        wgt = s * v
        sx += wgt * math.cos(2 * math.pi * hh)
        sy += wgt * math.sin(2 * math.pi * hh)
        wsum += wgt
        if 70 <= hh * 360 <= 170 and s > 0.15 and v > 0.1:
            green += 1
    hue = (math.degrees(math.atan2(sy, sx)) + 360) % 360 if wsum > 0 else 0.0
    return hue, green / max(1, len(px))


def distinct(px):
    return len(set(px))
