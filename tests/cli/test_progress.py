#!/usr/bin/env python3
"""Issue 15: long work reports progress when stderr is not a terminal.
`horizon render --generate perlin --size 4097` (several seconds) with stderr
to a file: plain lines "horizon: LABEL: P% (done/total)", no carriage return,
the percentages of a task rising by about 10 % per line (or a line every
10 s), ending at 100 %; the file is watched while the command runs, so the
lines are seen to arrive during the work, not at its end. With --quiet:
nothing. In a terminal (a pty): the bar, redrawn with carriage returns.

usage: test_progress.py HORIZON TMPDIR"""
import os, pty, re, select, shutil, subprocess, sys, time

HZ, TMP = sys.argv[1], os.path.abspath(sys.argv[2])
shutil.rmtree(TMP, ignore_errors=True)
os.makedirs(TMP)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from clitest import ok, bad, check, run_hz, finish  # noqa: E402,F401


LINE = re.compile(r"^horizon: (.+): (\d+)% \((\d+)/(\d+)\)$")
ARGS = ["render", "--generate", "perlin", "--size", "4097", "--seed", "5", "--width", "160", "--height", "90",
        "--out", os.path.join(TMP, "p.png")]
# Long enough that the lines after the first 2 s span several 10 % steps on
# a fast idle machine too (4097^2 is generated 85 % within those 2 s here).
ARGS_LONG = ["render", "--generate", "perlin", "--size", "8193", "--seed", "5", "--width", "160", "--height", "90",
             "--effects", "none", "--lod", "quadtree", "--out", os.path.join(TMP, "p.png")]

# 1. stderr to a file, watched while the command runs
errf = os.path.join(TMP, "err.txt")
with open(errf, "wb") as e:
    t0 = time.time()
    p = subprocess.Popen([HZ] + ARGS_LONG, stdout=subprocess.DEVNULL, stderr=e)
    seen = []  # (time, line) as the lines land in the file
    n = 0
    while True:
        done = p.poll() is not None
        data = open(errf, "rb").read()
        lines = data.split(b"\n")[:-1]
        for l in lines[n:]:
            seen.append((time.time() - t0, l.decode()))
        n = len(lines)
        if done:
            break
        time.sleep(0.05)
    total_s = time.time() - t0
raw = open(errf, "rb").read()
check(p.returncode == 0, "render exits 0 (%.1f s)" % total_s)
check(b"\r" not in raw, "no carriage return in the file")
prog = [(t, LINE.match(l)) for t, l in seen if LINE.match(l)]
other = [l for t, l in seen if not LINE.match(l)]
check(not other, "every line on stderr is a progress line (%s)" % other[:3])
tasks = {}
for t, m in prog:
    tasks.setdefault(m.group(1), []).append((t, int(m.group(2)), int(m.group(3)), int(m.group(4))))
gen = tasks.get("generate perlin", [])
print("lines:", [(round(t, 1), pc) for t, pc, _, _ in gen], "other tasks:", {k: len(v) for k, v in tasks.items()})
check(len(gen) >= 4, "%d progress lines for the generation (%.1f s)" % (len(gen), total_s))
if gen:
    pcts = [pc for _, pc, _, _ in gen]
    check(pcts[-1] == 100 and gen[-1][2] == gen[-1][3], "the generation's last line says 100 %")
    steps_ok = all(
        (b[1] - a[1] >= 10 or b[0] - a[0] >= 9.0 or b[1] == 100) and 0 < b[1] - a[1] <= 11
        for a, b in zip(gen, gen[1:]))
    check(steps_ok, "one line per 10 %% (or 10 s): %s" % pcts)
    check(gen[0][0] < total_s - 1.0 and gen[-2][0] < total_s - 0.5 if len(gen) > 1 else False,
          "the lines arrive while the work runs (first at %.1f s, command ended at %.1f s)" % (gen[0][0], total_s))
for label, v in tasks.items():
    check(all(b[1] > a[1] for a, b in zip(v, v[1:])), "%s: percentages rise" % label)

# 2. --quiet: nothing
p = subprocess.run([HZ] + ARGS + ["--quiet"], capture_output=True)
check(p.returncode == 0 and not LINE.search(p.stderr.decode()) and p.stderr == b"",
      "--quiet: no progress at all (%r)" % p.stderr[:80])

# 3. a terminal: the bar with carriage returns
mfd, sfd = pty.openpty()
p = subprocess.Popen([HZ] + ARGS[:4] + ["2049"] + ARGS[5:], stdout=subprocess.DEVNULL, stderr=sfd)
os.close(sfd)
buf = b""
while True:
    r, _, _ = select.select([mfd], [], [], 0.2)
    if r:
        try:
            chunk = os.read(mfd, 4096)
        except OSError:
            chunk = b""
        if not chunk:
            break
        buf += chunk
    elif p.poll() is not None:
        break
p.wait()
os.close(mfd)
check(p.returncode == 0 and b"\r" in buf and b"[####" in buf and b"horizon: generate perlin:" not in buf,
      "in a terminal: a bar redrawn with carriage returns, no plain lines")

finish()
