#!/usr/bin/env python3
"""Reads the firmware's telemetry frames (fw/telemetry.hpp; docs/telemetry.md).

compare_telemetry.py --drive D REF OUT     : same frames; every pose/parameter/K within 0.1 sigma
    [--same-counters]                      : and the drivers' counters (docs/telemetry.md, 7-15) equal in every frame
compare_telemetry.py --drive D --check-convergence OUT : the systematic parameters converged
    [--expect-faults]                      : and the last frame counts encoder jumps and damaged telegrams
"""
import argparse
import math
import struct
import sys

TRUTH = {"sync": [1.1, math.radians(1.0)], "diff": [1.1, 0.9, 1.1]}
# The drivers' counters (docs/telemetry.md, 1-based): what the encoder driver and the LMS2xx
# parser counted, and what became of the scans. They do not depend on floating point.
FAULT_COUNTERS = {7: "encoder jumps rejected", 8: "telegrams OK", 9: "bad CRC", 10: "truncated",
                  11: "wrong length", 12: "scans fused", 13: "scans late", 14: "scans overwritten",
                  15: "scans of the wrong size"}


def crc16(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def frames(path):
    try:
        data = open(path, "rb").read()
    except OSError as e:
        sys.exit(f"{path}: cannot read telemetry: {e.strerror}")
    out, off = [], 0
    while off + 6 <= len(data):
        if data[off] != 0xA5 or data[off + 1] != 0x5A:
            sys.exit(f"{path}: byte {off}: no frame sync")
        n = data[off + 3]
        frame = data[off:off + 6 + n]
        if len(frame) < 6 + n or crc16(frame[2:4 + n]) != struct.unpack_from("<H", frame, 4 + n)[0]:
            sys.exit(f"{path}: byte {off}: bad frame CRC")
        p = frame[4:4 + n]
        t, cycle = struct.unpack_from("<QI", p, 0)
        pose = struct.unpack_from("<3f", p, 12)
        psig = struct.unpack_from("<3f", p, 24)
        k = p[36]
        par = struct.unpack_from(f"<{k}f", p, 37)
        parsig = struct.unpack_from(f"<{k}f", p, 37 + 4 * k)
        o = 37 + 8 * k
        m = p[o]
        kk = struct.unpack_from(f"<{m}f", p, o + 1)
        ksig = struct.unpack_from(f"<{m}f", p, o + 1 + 4 * m)
        o += 1 + 8 * m
        c = p[o]
        counters = struct.unpack_from(f"<{c}I", p, o + 1)
        out.append({"t": t, "cycle": cycle, "v": list(pose) + list(par) + list(kk),
                    "s": list(psig) + list(parsig) + list(ksig), "par": par, "parsig": parsig,
                    "counters": counters})
        off += 6 + n
    if not out:
        sys.exit(f"{path}: no telemetry frames")
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--drive", required=True, choices=TRUTH)
    ap.add_argument("--check-convergence", action="store_true")
    ap.add_argument("--expect-faults", action="store_true")
    ap.add_argument("--same-counters", action="store_true")
    ap.add_argument("files", nargs="+")
    a = ap.parse_args()
    if a.check_convergence:
        f = frames(a.files[0])[-1]
        bad = 0
        for i, t in enumerate(TRUTH[a.drive]):
            v, s = f["par"][i], f["parsig"][i]
            ok = abs(v - t) <= 4 * s + (0.03 * t if a.drive == "diff" and i == 2 else 0)
            print(f"{'ok  ' if ok else 'FAIL'} param {i}: {v:.5f} (truth {t:.5f}, sigma {s:.5f})")
            bad += not ok
        print(f"{len(frames(a.files[0]))} frames, last at cycle {f['cycle']}")
        if a.expect_faults:
            print("last frame: " + ", ".join(f"{n} {f['counters'][i - 1]}" for i, n in FAULT_COUNTERS.items()))
            damaged = sum(f["counters"][i - 1] for i in (9, 10, 11))
            if f["counters"][6] == 0 or damaged == 0:
                print("FAIL: the tape's encoder jumps or damaged telegrams were not counted")
                bad += 1
        return 1 if bad else 0
    ref, out = frames(a.files[0]), frames(a.files[1])
    if len(ref) != len(out):
        print(f"FAIL: {len(ref)} reference frames vs {len(out)}")
        return 1
    worst = 0.0
    for r, o in zip(ref, out):
        if r["cycle"] != o["cycle"] or r["t"] != o["t"]:
            print(f"FAIL: frame at cycle {r['cycle']} t {r['t']} vs cycle {o['cycle']} t {o['t']}")
            return 1
        for i, (v, w, s) in enumerate(zip(r["v"], o["v"], r["s"])):
            d = abs(v - w)
            if i == 2 and d > math.pi:
                d = abs(d - 2 * math.pi)
            worst = max(worst, d / s if s > 0 else (0 if d == 0 else math.inf))
        if a.same_counters:
            for i in FAULT_COUNTERS:
                if r["counters"][i - 1] != o["counters"][i - 1]:
                    print(f"FAIL: cycle {r['cycle']}: counter {i} ({FAULT_COUNTERS[i]}) "
                          f"{r['counters'][i - 1]} vs {o['counters'][i - 1]}")
                    return 1
    print(f"{len(ref)} telemetry frames, same cycles and times, worst difference {worst:.4f} sigma")
    if a.same_counters:
        last = out[-1]["counters"]
        print("same driver counters in every frame; last: " +
              ", ".join(f"{n} {last[i - 1]}" for i, n in FAULT_COUNTERS.items()))
    return 1 if worst > 0.1 else 0


if __name__ == "__main__":
    sys.exit(main())
