#!/usr/bin/env python3
"""Writes footprint.json for a Cortex-M4F image (docs/performance.md explains the figures).

- text/data/bss: arm-none-eabi-size of the image.
- instructions_per_cycle: guest instructions counted by the odoerr_icount QEMU plugin while
  replaying the same drive for N1 and N2 cycles; (I(N2) - I(N1)) / (N2 - N1) removes the
  start-up, and the same difference for a dry run (tape decoded, filter skipped) removes
  the harness: what remains is one full cycle (predict, 36-beam update, OF).
- text/data/bss and stack_bytes_max: of the firmware application image (--firmware-elf),
  the stack from the start-up paint's high-water mark after a full 30 m drive over a HAL
  tape (drivers, parser, estimator, telemetry, calibration store all running).
- estimator_state_bytes: sizeof the estimator (AKF + OF + map + laser table), from the image.
- host_ns_per_cycle: the host build of the same program on the same tape, best of 5.
"""
import argparse
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time


def run_qemu(qemu, plugin, elf, workdir, count_file):
    cmd = qemu + ["-plugin", f"{plugin},out={count_file}", "-kernel", elf]
    r = subprocess.run(cmd, cwd=workdir, capture_output=True, timeout=600)
    if r.returncode != 0:
        sys.exit(f"footprint: {' '.join(cmd)} exited {r.returncode}: {r.stderr.decode()[-500:]}")
    return int(open(count_file).read().strip())


def tape_with_cycles(src, dst, cycles, dry=False):
    data = bytearray(open(src, "rb").read())
    struct.pack_into("<I", data, 12, cycles)  # header field 'cycles'
    if dry:  # bit 8 of the drive word: decode only, no filter
        (word,) = struct.unpack_from("<I", data, 8)
        struct.pack_into("<I", data, 8, word | 0x100)
    open(dst, "wb").write(data)


def tape_from_above(src, dst):
    """The tape with K starting 100x above the truth instead of 100x below (k0 x 10^4)."""
    data = bytearray(open(src, "rb").read())
    for off in (32, 36):  # header fields k0[0], k0[1]
        (k,) = struct.unpack_from("<f", data, off)
        struct.pack_into("<f", data, off, k * 1e4)
    open(dst, "wb").write(data)


def cycle_cost(qemu, plugin, elf, tape, workdir, n1=1000, n2=2000):
    """Guest instructions of one cycle of `elf` on `tape`: (I(n2) - I(n1)) / (n2 - n1) minus
    the same difference of a dry run (the harness)."""
    counts = {}
    for n, dry in ((n1, False), (n2, False), (n1, True), (n2, True)):
        d = os.path.join(workdir, f"{n}{'-dry' if dry else ''}")
        os.makedirs(d)
        tape_with_cycles(tape, os.path.join(d, "tape.bin"), n, dry)
        counts[(n, dry)] = run_qemu(qemu, plugin, os.path.abspath(elf), d, os.path.join(d, "count.txt"))
    harness = (counts[(n2, True)] - counts[(n1, True)]) / (n2 - n1)
    return (counts[(n2, False)] - counts[(n1, False)]) / (n2 - n1) - harness, harness


def symbol_sizes(nm, elf):
    """Sizes of the map table's objects in the image (arm-none-eabi-nm -S -C)."""
    out = subprocess.check_output([nm, "-S", "-C", elf]).decode()
    sizes = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 4 and parts[2] in "rRdDtT":
            name = " ".join(parts[3:])
            for key in ("kWalls", "kCells", "kCellItems", "kOdoerrMap"):
                if name.endswith(key):
                    sizes[key] = int(parts[1], 16)
    return sizes


# sizeof(odoerr::WallRec<float>): 8 floats (core/include/odoerr/map.hpp).
WALL_RECORD_BYTES = 32


def map_walls(sizes):
    """The map's walls from the size of its wall table (the grid's fence left out)."""
    table = sizes.get("kWalls", 0)
    if table % WALL_RECORD_BYTES:
        raise SystemExit(f"footprint: kWalls is {table} bytes, not a multiple of the "
                         f"{WALL_RECORD_BYTES}-byte wall record: has WallRec changed?")
    return table // WALL_RECORD_BYTES - (4 if "kCells" in sizes else 0)


def measure_map(qemu, plugin, nm, spec, workdir):
    """One entry of footprint.json's "maps": NAME=ELF,TAPE."""
    name, rest = spec.split("=", 1)
    elf, tape = rest.split(",")
    ipc, _ = cycle_cost(qemu, plugin, elf, tape, os.path.join(workdir, name))
    sizes = symbol_sizes(nm, elf)
    header = open(tape, "rb").read(20)
    (word,) = struct.unpack_from("<I", header, 8)
    (beams,) = struct.unpack_from("<I", header, 16)
    used = (word >> 16) & 0xFFF
    d = os.path.join(workdir, name + "-full")
    os.makedirs(d)
    shutil.copy(tape, os.path.join(d, "tape.bin"))
    run_qemu(qemu, plugin, os.path.abspath(elf), d, os.path.join(d, "count.txt"))
    data = open(os.path.join(d, "out.bin"), "rb").read()
    off = data.rfind(struct.pack("<I", 0xFFFFFFFF))
    fused, rejected = struct.unpack_from("<2I", data, off + 4)
    cycles = struct.unpack_from("<I", open(tape, "rb").read(), 12)[0]
    return {
        "name": name,
        # kWalls holds the map's walls, then the grid's fence (4 walls) when there is a grid.
        "segments": map_walls(sizes),
        "beams_per_scan": beams,
        "beams_used": used if used else beams,
        "beams_fused_per_cycle": round(fused / cycles, 2),
        "beams_rejected_per_cycle": round(rejected / cycles, 2),
        "instructions_per_cycle": round(ipc),
        "map_flash_bytes": sum(sizes.values()),
        "image": os.path.basename(elf),
    }


def trailer(path):
    data = open(path, "rb").read()
    off = data.rfind(struct.pack("<I", 0xFFFFFFFF))
    vals = struct.unpack_from("<5I", data, off + 4)
    return {"stack": vals[3], "estimator": vals[4]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elf", required=True)
    ap.add_argument("--size-tool", default="arm-none-eabi-size")
    ap.add_argument("--plugin", required=True)
    ap.add_argument("--tape", required=True, help="host tape of the primary drive")
    ap.add_argument("--host-replay", required=True)
    ap.add_argument("--batch-elf", help="textbook batch EKF image of the same cycle (comparison)")
    ap.add_argument("--ml-elf", help="the same cycle with the ML estimator of K in the OF's place (core_replay_ml)")
    ap.add_argument("--sync-tape", help="host tape of the synchronous drive: the paper's cycle and --ml-elf's on it too")
    ap.add_argument("--firmware-elf", help="the firmware application image (sizes, stack)")
    ap.add_argument("--hal-tape", help="HAL tape for the firmware image")
    ap.add_argument("--out", required=True)
    ap.add_argument("--drive", default="diff")
    ap.add_argument("--map", action="append", default=[], help="NAME=ELF,TAPE: a map image and its drive")
    ap.add_argument("--nm-tool", default="arm-none-eabi-nm")
    ap.add_argument("qemu", nargs=argparse.REMAINDER, help="-- qemu command without -kernel")
    a = ap.parse_args()
    qemu = [x for x in a.qemu if x != "--"]
    if qemu and qemu[-1] == "-kernel":
        qemu = qemu[:-1]
    for path in (a.elf, a.plugin, a.tape, a.host_replay):
        if not os.path.exists(path):
            sys.exit(f"footprint: missing {path}")
    image = a.firmware_elf or a.elf
    text, data, bss = map(int, subprocess.check_output([a.size_tool, image]).decode().splitlines()[1].split()[:3])
    cycles_total = struct.unpack_from("<I", open(a.tape, "rb").read(), 12)[0]
    n1, n2 = 1000, 2000
    counts = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n, dry in ((n1, False), (n2, False), (cycles_total, False), (n1, True), (n2, True)):
            d = os.path.join(tmp, f"{n}{'-dry' if dry else ''}")
            os.makedirs(d)
            tape_with_cycles(a.tape, os.path.join(d, "tape.bin"), n, dry)
            counts[(n, dry)] = run_qemu(qemu, a.plugin, os.path.abspath(a.elf), d, os.path.join(d, "count.txt"))
        t = trailer(os.path.join(tmp, str(cycles_total), "out.bin"))
        fw_stats = None
        if a.firmware_elf and a.hal_tape:
            d = os.path.join(tmp, "firmware")
            os.makedirs(d)
            shutil.copy(a.hal_tape, os.path.join(d, "haltape.bin"))
            run_qemu(qemu, a.plugin, os.path.abspath(a.firmware_elf), d, os.path.join(d, "count.txt"))
            vals = struct.unpack("<4I", open(os.path.join(d, "fwstats.bin"), "rb").read())
            fw_stats = {"stack": vals[0], "estimator": vals[1], "app": vals[2], "cycles": vals[3]}
        batch = None
        if a.batch_elf:
            batch, _ = cycle_cost(qemu, a.plugin, a.batch_elf, a.tape, os.path.join(tmp, "batch"), n1, n2)
        ml = None
        if a.ml_elf:
            ml, _ = cycle_cost(qemu, a.plugin, a.ml_elf, a.tape, os.path.join(tmp, "ml"), n1, n2)
        sync = None
        if a.sync_tape and a.ml_elf:
            paper_s, _ = cycle_cost(qemu, a.plugin, a.elf, a.sync_tape, os.path.join(tmp, "sync"), n1, n2)
            ml_s, _ = cycle_cost(qemu, a.plugin, a.ml_elf, a.sync_tape, os.path.join(tmp, "sync-ml"), n1, n2)
            # From 100x above, the first 3 m (cycles 5-305, 30 K steps): the ML's falling steps
            # iterate their solve there (KMlConfig::solve_iters).
            above = os.path.join(tmp, "sync-above.bin")
            tape_from_above(a.sync_tape, above)
            ml_a, _ = cycle_cost(qemu, a.plugin, a.ml_elf, above, os.path.join(tmp, "sync-ml-above"), 5, 305)
            sync = {"instructions_per_cycle": round(paper_s), "of_ml_instructions_per_cycle": round(ml_s),
                    "of_ml_over_paper_of": round(ml_s / paper_s, 2),
                    "of_ml_from_above_first_3_m_instructions_per_cycle": round(ml_a)}
        maps = [measure_map(qemu, a.plugin, a.nm_tool, spec, tmp) for spec in a.map]
        best = None
        for _ in range(5):
            t0 = time.perf_counter()
            subprocess.run([a.host_replay, a.tape, os.path.join(tmp, "host.bin")], check=True)
            dt = time.perf_counter() - t0
            best = dt if best is None else min(best, dt)
    harness = (counts[(n2, True)] - counts[(n1, True)]) / (n2 - n1)
    ipc = (counts[(n2, False)] - counts[(n1, False)]) / (n2 - n1) - harness
    fp = {
        "image": os.path.basename(image),
        "drive": a.drive,
        "text_bytes": text,
        "data_bytes": data,
        "bss_bytes": bss,
        "flash_bytes": text + data,
        "stack_bytes_max": fw_stats["stack"] if fw_stats else t["stack"],
        "estimator_state_bytes": t["estimator"],
        "application_state_bytes": fw_stats["app"] if fw_stats else None,
        "cycle_image": os.path.basename(a.elf),
        "instructions_per_cycle": round(ipc),
        "harness_instructions_per_cycle": round(harness),
        "batch_textbook_instructions_per_cycle": round(batch) if batch else None,
        "batch_over_sequential": round(batch / ipc, 1) if batch else None,
        # --of ml's estimator of K in the OF's place, the rest of the cycle the same (issue 15).
        "of_ml": {"image": os.path.basename(a.ml_elf), "instructions_per_cycle": round(ml),
                  "over_paper_of": round(ml / ipc, 2)} if ml else None,
        # The same two images on the synchronous drive's tape (its ML step iterates from above).
        "sync": sync,
        "instructions_whole_drive": counts[(cycles_total, False)],
        "cycles_whole_drive": cycles_total,
        "host_ns_per_cycle": round(best * 1e9 / cycles_total),
        # 100 cycles/s at 1 m/s; one instruction ~ one clock on the M4 (FPU ops single-cycle).
        "cpu_share_pct_at_1_m_per_s_168_MHz": round(ipc * 100 / 168e6 * 100, 2),
        "maps": maps,
    }
    with open(a.out, "w") as f:
        json.dump(fp, f, indent=2)
        f.write("\n")
    print(json.dumps(fp, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
