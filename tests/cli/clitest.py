"""What every Python CLI test shares: the tally of its checks (each printed
as "ok   ..." or "FAIL ...") and running the horizon program."""
import subprocess
import sys

_count = {"pass": 0, "fail": 0}


def ok(msg):
    _count["pass"] += 1
    print("ok   " + msg, flush=True)


def bad(msg):
    _count["fail"] += 1
    print("FAIL " + msg, flush=True)


def check(cond, msg, detail=""):
    """ok(msg) when cond holds, else bad(msg) with detail (cut to 600
    characters). Returns cond."""
    if cond:
        ok(msg)
    else:
        bad(msg + (": " + str(detail)[:600] if detail != "" else ""))
    return cond


def run_hz(hz, args, timeout=300):
    """Runs hz with args: (exit code, stdout, stderr) as text."""
    p = subprocess.run([hz] + list(args), capture_output=True, timeout=timeout)
    return p.returncode, p.stdout.decode("utf-8", "replace"), p.stderr.decode("utf-8", "replace")


def finish(name=""):
    """Prints the tally and exits non-zero when a check failed."""
    print("%s%d passed, %d failed" % (name + ": " if name else "", _count["pass"], _count["fail"]))
    sys.exit(1 if _count["fail"] else 0)
