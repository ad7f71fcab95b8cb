#!/usr/bin/env python3
"""Reads core-replay outputs (firmware/include/odoerr/fw/tape.hpp, "ODOU" records).

compare_replay.py --drive D REF OUT   : OUT reproduces REF within 0.1 sigma at every record
                                        (and reports how many values are bit-identical)
compare_replay.py --drive D --check-convergence OUT : the systematic parameters converged
compare_replay.py --drive D --summary OUT : prints the trailer (counts, stack) as JSON
compare_replay.py --drive D --check-health --beams B OUT : every record finite with positive
                                        sigmas, and every beam offered (cycles x B) counted
                                        as used or rejected (the soak, docs/reliability.md)
"""
import argparse
import json
import math
import struct
import sys

DIMS = {"sync": (5, 2), "diff": (6, 1)}
TRUTH = {"sync": [1.1, math.radians(1.0)], "diff": [1.1, 0.9, 1.1]}


def load(path, drive):
    n, k = DIMS[drive]
    width = 4 * (1 + 2 * n + 2 * k)
    try:
        data = open(path, "rb").read()
    except OSError as e:
        sys.exit(f"{path}: cannot read replay output: {e.strerror}")
    recs, off = [], 0
    while off + 4 <= len(data):
        (tag,) = struct.unpack_from("<I", data, off)
        if tag == 0xFFFFFFFF:
            used, rejected, of_updates, stack, est = struct.unpack_from("<5I", data, off + 4)
            return recs, {"beams_used": used, "beams_rejected": rejected, "of_updates": of_updates,
                          "stack_high_water_bytes": stack, "estimator_bytes": est}
        if off + width > len(data):
            break
        vals = struct.unpack_from("<I" + "f" * (2 * n + 2 * k), data, off)
        recs.append({"cycle": vals[0], "x": vals[1:1 + n], "sx": vals[1 + n:1 + 2 * n],
                     "k": vals[1 + 2 * n:1 + 2 * n + k], "sk": vals[1 + 2 * n + k:]})
        off += width
    sys.exit(f"{path}: truncated output after {len(recs)} records (no trailer)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--drive", required=True, choices=DIMS)
    ap.add_argument("--check-convergence", action="store_true")
    ap.add_argument("--summary", action="store_true")
    ap.add_argument("--check-health", action="store_true")
    ap.add_argument("--beams", type=int, default=36)
    ap.add_argument("files", nargs="+")
    a = ap.parse_args()
    if a.summary:
        _, trailer = load(a.files[0], a.drive)
        print(json.dumps(trailer))
        return 0
    if a.check_health:
        recs, trailer = load(a.files[0], a.drive)
        if not recs:
            print("FAIL: no records")
            return 1
        bad = 0
        min_sigma = math.inf
        for r in recs:
            vals = r["x"] + r["k"] + r["sx"] + r["sk"]
            sig = r["sx"] + r["sk"]
            if not all(math.isfinite(v) for v in vals) or not all(s > 0 for s in sig):
                print(f"FAIL: record at cycle {r['cycle']}: not finite or a sigma not positive")
                bad += 1
            min_sigma = min([min_sigma] + [s for s in r["sx"]])
        cycles = recs[-1]["cycle"]
        offered = cycles * a.beams
        counted = trailer["beams_used"] + trailer["beams_rejected"]
        print(f"{len(recs)} records over {cycles} cycles, all finite with positive sigmas: {bad == 0}; "
              f"smallest state sigma {min_sigma:.3g}; beams offered {offered}, used {trailer['beams_used']}, "
              f"rejected {trailer['beams_rejected']} (counted {counted})")
        if counted != offered:
            print("FAIL: beams offered and beams counted differ")
            bad += 1
        return 1 if bad else 0
    if a.check_convergence:
        recs, trailer = load(a.files[0], a.drive)
        last = recs[-1]
        n, _ = DIMS[a.drive]
        bad = 0
        for i, t in enumerate(TRUTH[a.drive]):
            v, s = last["x"][3 + i], last["sx"][3 + i]
            ok = abs(v - t) <= 4 * s + 0.02 * abs(t) if a.drive == "diff" and i == 2 else abs(v - t) <= 4 * s
            print(f"{'ok  ' if ok else 'FAIL'} param {i}: {v:.5f} (truth {t:.5f}, sigma {s:.5f})")
            bad += not ok
        print(f"cycles {last['cycle']}, beams used {trailer['beams_used']}, OF updates {trailer['of_updates']}")
        return 1 if bad else 0
    ref, rt = load(a.files[0], a.drive)
    out, ot = load(a.files[1], a.drive)
    if len(ref) != len(out):
        print(f"FAIL: {len(ref)} reference records vs {len(out)}")
        return 1
    worst, identical, total = 0.0, 0, 0
    for r, o in zip(ref, out):
        for v, w, s in zip(r["x"] + r["k"], o["x"] + o["k"], r["sx"] + r["sk"]):
            total += 1
            identical += struct.pack("<f", v) == struct.pack("<f", w)
            d = abs(v - w)
            if d > math.pi and s < 1:  # heading wrap
                d = abs(d - 2 * math.pi)
            worst = max(worst, d / s if s > 0 else (0 if d == 0 else math.inf))
    print(f"{len(ref)} records, {identical}/{total} values bit-identical, worst difference "
          f"{worst:.4f} sigma; beams used {rt['beams_used']} vs {ot['beams_used']}")
    if worst > 0.1:
        print("FAIL: differs by more than 0.1 sigma")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
