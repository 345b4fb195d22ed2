#!/usr/bin/env python3
"""Every DEM of the data folder through --dem: size, CRS, spacing x/y in metres
and the samples shown against the samples in the file. Markdown on stdout.
   bench/dems.py HORIZON DATA_DIR WORK_DIR"""
import json, os, subprocess, sys

HZ, DATA, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
os.makedirs(WORK, exist_ok=True)
EXTRA = {  # what a user must say about a file that says nothing itself
    "sierra_nevada_N36-N40_W122-W118_srtm3_4801x4801_int16be.raw.gz": ["--raw-size", "4801x4801"],
}
names = sorted(f for f in os.listdir(DATA)
               if not f.endswith((".md", ".properties")) and not os.path.isdir(os.path.join(DATA, f)))
names += sorted(d for d in os.listdir(DATA) if d.startswith("srtm_") and os.path.isdir(os.path.join(DATA, d)))
print("\n## Every DEM through --dem\n")
print("Geographic files are reprojected to square cells at their finer spacing, so the metric grid")
print("holds more samples than the file; nothing is cropped.\n")
print("| DEM | file size | CRS | spacing x / y (m) | grid shown | samples shown / in the file |")
print("|---|---|---|---|---|---|")
for n in names:
    path = os.path.join(DATA, n)
    info = subprocess.run([HZ, "info", "--json", path], capture_output=True, text=True)
    try:
        i = json.loads(info.stdout)[0]
    except (ValueError, IndexError):
        i = {}
    r = subprocess.run([HZ, "render", "--dem", path, "--width", "160", "--height", "90", "--repeat", "1",
                        "--quiet", "--json", "--out", os.path.join(WORK, n.replace("/", "_") + ".png")] + EXTRA.get(n, []),
                       capture_output=True, text=True)
    try:
        j = json.loads(r.stdout)
    except ValueError:
        msg = (r.stderr.strip().splitlines() or ["?"])[-1]
        print(f"| {n} | {i.get('width', '?')}×{i.get('height', '?')} | {i.get('crs', '—')} | — | not rendered: {msg} | — |")
        continue
    sp = i.get("spacing_m") or [j.get("spacing"), j.get("spacing")]
    shown, total = j.get("samples_valid", 0), j.get("file_samples", 0)
    ds = j.get("data_size", ["?", "?"])
    pct = f"{100.0*shown/total:.1f} %" if total else "—"
    print(f"| {n} | {i.get('width', '?')}×{i.get('height', '?')} | {i.get('crs') or 'none'} | "
          f"{sp[0]:.2f} / {sp[1]:.2f} | {ds[0]}×{ds[1]} at {j.get('spacing', 0):.2f} m | "
          f"{shown:,} / {total:,} ({pct}) |")
