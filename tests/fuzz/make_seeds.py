#!/usr/bin/env python3
"""Writes the hand-made seed inputs of the fuzz corpora (tests/fuzz/corpus/<target>/seed-*).

The corpora in the repository are these seeds merged with what the fuzzers found, minimised
with -merge=1 (docs/reliability.md, "Fuzzing"). Usage: python3 tests/fuzz/make_seeds.py DIR
(DIR gets lms2xx/, odolog/, calibration_store/)."""
import math
import os
import struct
import sys
import zlib


def lms_crc16(data):
    crc, prev = 0, 0
    for b in data:
        crc = (((crc & 0x7FFF) << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1) & 0xFFFF
        crc ^= (prev << 8) | b
        prev = b
    return crc & 0xFFFF


def lms_telegram(cmd, data, status=0x10, adr=0x80):
    body = bytes([cmd]) + bytes(data) + bytes([status])
    t = bytes([0x02, adr]) + struct.pack("<H", len(body)) + body
    return t + struct.pack("<H", lms_crc16(t))


def lms_scan(values, unit_mm=False, partial=None, rt_index=None):
    word = len(values) | (0x4000 if unit_mm else 0)
    if partial is not None:
        word |= 0x2000 | (partial << 11)
    data = struct.pack("<H", word) + b"".join(struct.pack("<H", v) for v in values)
    if rt_index is not None:
        data += bytes([rt_index])
    return lms_telegram(0xB0, data)


def cal_record(seq, drive, count, values, variances):
    vals = (list(values) + [0.0] * 8)[:8]
    vars_ = (list(variances) + [0.0] * 8)[:8]
    rec = struct.pack("<IBIH", 0x4C41434F, 1, seq, 66) + bytes([drive, count])
    rec += b"".join(struct.pack("<f", v) for v in vals) + b"".join(struct.pack("<f", v) for v in vars_)
    return rec + struct.pack("<I", zlib.crc32(rec) & 0xFFFFFFFF)


def slot(rec, sector=128):
    return rec + b"\xff" * (sector - len(rec))


def main():
    out = sys.argv[1]
    seeds = {"lms2xx": {}, "odolog": {}, "calibration_store": {}}
    # LMS2xx: byte 0 = config, byte 1 = chunking (fuzz_lms2xx.cpp), then the line.
    s181 = lms_scan([(200 + 3 * i) for i in range(181)])
    seeds["lms2xx"]["seed-181cm"] = b"\x00\x01" + s181
    seeds["lms2xx"]["seed-mm-codes"] = b"\x83\x20" + lms_scan([0x1FF7, 0x1FFA, 0x1FFF, 0x9000, 8182], unit_mm=True)
    seeds["lms2xx"]["seed-partial-rt"] = b"\x05\x41" + lms_scan([100, 200, 0x7FFF], partial=2, rt_index=7)
    seeds["lms2xx"]["seed-noise-two"] = (b"\x40\x11" + b"\x02\x80\xff\x7f\x00" + s181[:50] +
                                         lms_telegram(0xA0, b"\x00") + lms_scan([1, 2, 3]))
    seeds["lms2xx"]["seed-request"] = b"\x00\x01" + bytes.fromhex("020002002024 3408".replace(" ", ""))
    # odolog v1 texts.
    header = ("odolog 1\n# a comment\ndrive diff\nparam wheel_radius_m 0.05\nparam ticks_per_rev 4096\n"
              "param wheelbase_m 0.5   # trailing comment\nlaser 2 -1.5 3.0 20.0 0.03 0.0 0.0 0.0\n"
              "wall 0 0 10 0\ninit 5.0 1.0 0.0 0.01 0.01 0.0175\n")
    seeds["odolog"]["seed-diff"] = (header + "meta source fuzz\nenc 0.0 0 0\nfuture_record 1 2 3\n"
                                    "scan 0.01 5.0 nan\npose 0.02 5 1 0 0.1 0.1 0.01\n"
                                    "truth 0.02 5.001 1.0 0.0\nenc 0.02 -131 129\n").encode()
    sync = ["odolog 1", "drive sync", "param wheel_radius_m 0.05", "param ticks_per_rev 2000",
            "laser 3 -1.0 1.0 8.0 0.02 0.1 0.0 0.0", "wall -2 -2 2 -2", "wall 2 -2 2 2",
            "init 0 0 0 0.01 0.01 0.01"]
    for k in range(12):
        t = 0.1 * k
        sync.append("enc %.2f %d %d" % (t, 40 * k, 3 * k))
        if k % 3 == 0:
            sync.append("scan %.2f %.3f %.3f %s" % (t + 0.01, 1.9 - 0.01 * k, 2.0, "nan" if k == 6 else "2.1"))
        sync.append("truth %.2f %.4f 0 %.4f" % (t, 0.01 * k, 0.0003 * k))
    seeds["odolog"]["seed-sync"] = ("\n".join(sync) + "\n").encode()
    seeds["odolog"]["seed-bad-enc"] = b"odolog 1\ndrive diff\nenc 0 1\n"
    # Calibration store: two 128-byte sectors.
    a = cal_record(7, 1, 3, [1.0, 0.5, -0.25], [1e-4, 2e-4, 3e-4])
    b = cal_record(8, 1, 2, [1.01, 0.49], [1e-4, 1e-4])
    seeds["calibration_store"]["seed-two-slots"] = slot(a) + slot(b)
    seeds["calibration_store"]["seed-wrap"] = slot(cal_record(0xFFFFFFFF, 2, 8, [0.1] * 8, [1.0] * 8)) + slot(cal_record(0, 2, 0, [], []))
    torn = bytearray(b)
    torn[40] &= 0x0F
    seeds["calibration_store"]["seed-torn"] = slot(a) + slot(bytes(torn[:77]) + b"\xff\xff\xff\xff")
    seeds["calibration_store"]["seed-nan"] = slot(cal_record(3, 1, 2, [math.nan, 1.0], [1.0, -1.0])) + b"\xff" * 128
    for target, files in seeds.items():
        d = os.path.join(out, target)
        os.makedirs(d, exist_ok=True)
        for name, data in files.items():
            with open(os.path.join(d, name), "wb") as f:
                f.write(data)


if __name__ == "__main__":
    main()
