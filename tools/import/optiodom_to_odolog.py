#!/usr/bin/env python3
"""optiodom_to_odolog.py: one OptiOdom differential-drive run -> one odolog v1 file.

Usage:
    optiodom_to_odolog.py RUN_CSV --out FILE [--fix-period S] [--fix-sigma-xy M]
                          [--fix-sigma-theta RAD]

Source: the OptiOdom data set (Sousa, Petry, Costa, Moreira, J. Intell. Robot. Syst. 105,
39 (2022); MIT licence), kept beside the project at ../shared/data/optiodom-diff (see its
README.md). One run is a CSV file without header, one row every 0.05 s (20 Hz):
    time, x, y, theta   (motion capture: robot centre, re-zeroed at the start; theta
                         continuous, not wrapped)
    nR, nL              (right / left wheel ticks counted in this 50 ms cycle: increments)
Some files begin with a UTF-8 byte-order mark; it is ignored. The first row is all zeros.
The rows already pair each mocap sample with the ticks of the same cycle (the source's
authors synchronised the two streams; the per-set *_metadata.csv trimming windows are
therefore not needed and not read).

Mapping (format: docs/odolog.md):
- `drive diff` with the nominal robot of the README for every run: wheel diameter 0.084 m
  -> `param wheel_radius_m 0.042`; gear 43.7 x 64 ticks per motor revolution ->
  `param ticks_per_rev 2796.8` (ticks per WHEEL revolution); `param wheelbase_m 0.2`.
  The Li = 0.205 / Di = 0.085 found in some metadata files were controller settings of
  the day, not another robot, and are ignored (README).
- `init` at the first mocap pose with sigmas 0.002 m, 0.002 m, 0.005 rad (the mocap is
  far better than that; the prior only has to be honest, not tight).
- one `enc T A B` per row, A = right, B = left, CUMULATIVE counts: the running sum of the
  nR / nL increments up to and including the row (the first row's increments are zero,
  so the log starts at `enc 0.000000 0 0`).
- one `truth T X Y THETA` per row from the mocap; theta is written as in the source
  (continuous, unwrapped; odolog does not require wrapping and readers compare angles
  modulo 2 pi).
- a `pose` fix (usable as an observation) from the same mocap sample every --fix-period
  seconds (default 1.0 s; 0 = no fixes): at the first row with t >= t0 + k*period,
  k = 1, 2, ... (no fix at t0: the init record already holds that pose), with sigmas
  --fix-sigma-xy (0.005 m) and --fix-sigma-theta (0.01 rad). The fixes are the raw mocap
  values, with no noise added; the sigmas are deliberately conservative.
- no `laser`, no `wall`: the data set has no range finder and no map.
- times are written with 6 decimals (the source's 0.0499999999992724 style float noise
  becomes 0.050000); x, y with 6 decimals (1 um), theta with 7.
- `meta source optiodom <path>` (the path relative to the optiodom-diff folder when the
  file lies inside it, so that the output does not depend on where the data set is
  mounted), `meta licence MIT (see ../shared/data/optiodom-diff/LICENSE)`, the SHA-256
  of the input and the fix settings. The output depends only on the input bytes and the
  options: running the importer twice gives identical files.

Malformed input (a row without exactly 6 comma-separated fields, a field that is not a
finite decimal number, a tick increment that is not an integer, time going backwards,
bytes that are not UTF-8, no rows at all) is refused with `FILE:LINE: what is wrong` on
stderr and exit status 2; nothing is written then (the output is written to a temporary
file and renamed only on success). Bad options also exit 2.
"""

import hashlib
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from import_common import InputError, Parser, decoded_lines, parse_number, run, write_atomic  # noqa: E402


WHEEL_DIAMETER_M = 0.084
GEAR_RATIO = 43.7
TICKS_PER_MOTOR_REV = 64
WHEELBASE_M = 0.200
INIT_SIGMA = (0.002, 0.002, 0.005)

# A decimal number as odolog and the source write it; Python's float() alone would also
# take "1_000", "infinity", "0x10"-like oddities, so the token is matched first.
BOM = b"\xef\xbb\xbf"


def fmt(v):
    """Short, exact-enough text for a configuration value (sigmas, periods)."""
    return repr(float(v)) if float(v) != int(v) else str(int(v))


def read_rows(path):
    """Returns [(line_no, t, x, y, theta, nR, nL)] and the SHA-256 of the file."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise InputError(f"{path}: cannot read: {e.strerror or e}") from None
    digest = hashlib.sha256(data).hexdigest()
    if data.startswith(BOM):
        data = data[len(BOM):]
    rows = []
    prev_t = None
    names = ("time", "x", "y", "theta", "nR", "nL")
    for no, where, line in decoded_lines(data.split(b"\n"), path, "utf-8", "valid UTF-8 text"):
        line = line.strip()
        if not line:
            continue  # blank lines (the final newline, a CRLF leftover) carry nothing
        fields = [s.strip() for s in line.split(",")]
        if len(fields) != 6:
            raise InputError(f"{where}: expected 6 comma-separated fields "
                             f"(time,x,y,theta,nR,nL), got {len(fields)}")
        vals = [parse_number(tok, where, name) for tok, name in zip(fields, names)]
        t, x, y, th, nr, nl = vals
        for v, name in ((nr, "nR"), (nl, "nL")):
            if v != math.floor(v):
                raise InputError(f"{where}: {name}: '{fields[names.index(name)]}' is not an integer tick count")
            if abs(v) > 2**40:
                raise InputError(f"{where}: {name}: tick increment {v:.0f} is implausibly large")
        if prev_t is not None and t < prev_t:
            raise InputError(f"{where}: time goes backwards: t={fields[0]} after t={prev_t!r}")
        prev_t = t
        rows.append((no, t, x, y, th, int(nr), int(nl)))
    if not rows:
        raise InputError(f"{path}: no data rows")
    return rows, digest


def source_name(path):
    """The path relative to the optiodom-diff folder when inside it, else as given."""
    parts = os.path.normpath(os.path.abspath(path)).split(os.sep)
    if "optiodom-diff" in parts:
        i = len(parts) - 1 - parts[::-1].index("optiodom-diff")
        path = "/".join(parts[i:])
    # a '#' would start an odolog comment, a line break would end the record
    return "".join("%{:02X}".format(ord(c)) if c in "#\r\n" else c for c in path)


def convert(rows, path, digest, period, sig_xy, sig_th):
    out = []
    w = out.append
    t0, x0, y0, th0 = rows[0][1:5]
    w("odolog 1")
    w("# OptiOdom differential-drive run converted by tools/import/optiodom_to_odolog.py")
    w("# enc: cumulative sums of the per-cycle nR/nL increments (A = right, B = left);")
    w("# truth: mocap at every row; pose: the same mocap used as a fix every fix period.")
    w(f"meta source optiodom {source_name(path)}")
    w("meta licence MIT (see ../shared/data/optiodom-diff/LICENSE)")
    w("meta credit R.B. Sousa, M.R. Petry, P.G. Costa, A.P. Moreira, OptiOdom, "
      "J. Intell. Robot. Syst. 105, 39 (2022), doi:10.1007/s10846-022-01630-3")
    w(f"meta source_sha256 {digest}")
    w("meta importer tools/import/optiodom_to_odolog.py")
    if period > 0:
        w(f"meta pose_fixes mocap every {fmt(period)} s, sigma {fmt(sig_xy)} m {fmt(sig_th)} rad")
    else:
        w("meta pose_fixes none")
    w("meta nominal gear 43.7 x 64 ticks per motor rev, wheel diameter 0.084 m, "
      "wheelbase 0.200 m (README; metadata Li/Di ignored)")
    w("drive diff")
    w(f"param wheel_radius_m {fmt(WHEEL_DIAMETER_M / 2)}")
    w(f"param ticks_per_rev {fmt(round(GEAR_RATIO * TICKS_PER_MOTOR_REV, 6))}")
    w(f"param wheelbase_m {fmt(WHEELBASE_M)}")
    w(f"init {x0:.6f} {y0:.6f} {th0:.7f} {fmt(INIT_SIGMA[0])} {fmt(INIT_SIGMA[1])} {fmt(INIT_SIGMA[2])}")
    cum_r = cum_l = 0
    k = 1
    tol = 1e-6
    n_fix = 0
    for (_no, t, x, y, th, nr, nl) in rows:
        cum_r += nr
        cum_l += nl
        w(f"enc {t:.6f} {cum_r} {cum_l}")
        w(f"truth {t:.6f} {x:.6f} {y:.6f} {th:.7f}")
        if period > 0 and t >= t0 + k * period - tol:
            w(f"pose {t:.6f} {x:.6f} {y:.6f} {th:.7f} {fmt(sig_xy)} {fmt(sig_xy)} {fmt(sig_th)}")
            n_fix += 1
            k = int(math.floor((t - t0 + tol) / period)) + 1
    return "\n".join(out) + "\n", n_fix, cum_r, cum_l


def main(argv=None):
    ap = Parser(prog="optiodom_to_odolog.py",
                description="Convert one OptiOdom run CSV to an odolog v1 file.")
    ap.add_argument("run_csv", metavar="RUN_CSV")
    ap.add_argument("--out", required=True, metavar="FILE")
    ap.add_argument("--fix-period", type=float, default=1.0, metavar="S",
                    help="seconds between mocap pose fixes (0 = none; default 1.0)")
    ap.add_argument("--fix-sigma-xy", type=float, default=0.005, metavar="M")
    ap.add_argument("--fix-sigma-theta", type=float, default=0.01, metavar="RAD")
    a = ap.parse_args(argv)
    if not (math.isfinite(a.fix_period) and a.fix_period >= 0):
        ap.error("--fix-period must be a finite number >= 0")
    for name, v in (("--fix-sigma-xy", a.fix_sigma_xy), ("--fix-sigma-theta", a.fix_sigma_theta)):
        if not (math.isfinite(v) and v > 0):
            ap.error(f"{name} must be a finite number > 0")
    try:
        rows, digest = read_rows(a.run_csv)
        text, n_fix, cum_r, cum_l = convert(rows, a.run_csv, digest, a.fix_period,
                                            a.fix_sigma_xy, a.fix_sigma_theta)
        write_atomic(a.out, text)
    except InputError as e:
        sys.stderr.write(f"error: {e}\n")
        return 2
    sys.stderr.write(f"{a.out}: {len(rows)} rows, {rows[-1][1] - rows[0][1]:.2f} s, "
                     f"{n_fix} pose fixes, final ticks R {cum_r} L {cum_l}\n")
    return 0


if __name__ == "__main__":
    run(main)
