#!/usr/bin/env python3
"""Writes the STM32F405 board's footprint.json (docs/porting.md explains the figures).

    board_footprint.py --elf fw_board.elf --plugin libodoerr_icount.so --hal-tape haltape.bin
                       --out footprint.json -- qemu-system-arm -M netduinoplus2 ...

- text/data/bss: arm-none-eabi-size of the firmware application image; flash = text + data;
  static RAM = data + bss without the stack the linker script reserves.
- stack_bytes_max: the start-up paint's high-water mark after the whole drive (fwstats.bin).
- instructions_per_cycle: guest instructions counted by the odoerr_icount QEMU plugin while the
  image replays the tape cut to N1 and to N2 polls, (I(N2) - I(N1)) / (cycles(N2) - cycles(N1)):
  the whole application between those polls (1 ms polls, USART1's receive interrupt for each
  laser byte, the parser, the estimator's cycle, telemetry out on USART2) and the reading of
  the tape's records through semihosting. The test seam's wait for the feeder's bytes
  (UsartFeed::waitFor) is left out: its length depends on the host's timing.
- cpu_share_pct_at_1_m_per_s_168_MHz: the tape's drive goes at 1 m/s, 100 cycles a second;
  one instruction taken as one clock of a 168 MHz M4F.
"""
import argparse
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile

POLLS_OFFSET = 48  # fw/hal_tape.hpp: the header's poll count
FEED = os.path.join(os.path.dirname(os.path.abspath(__file__)), "board_feed.py")


def wait_range(nm, elf):
    """[lo, hi) of the feed's wait function, the Thumb bit cleared."""
    out = subprocess.check_output([nm, "-S", "-C", elf]).decode()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) >= 4 and parts[2] in "tT" and "UsartFeed::waitFor" in " ".join(parts[3:]):
            lo = int(parts[0], 16) & ~1
            return lo, lo + int(parts[1], 16)
    sys.exit(f"board_footprint: no UsartFeed::waitFor in {elf}")


def run(qemu, plugin, elf, tape, polls, workdir, exclude):
    """Runs the image on the tape cut to `polls` polls: (instructions, fwstats)."""
    os.makedirs(workdir)
    data = bytearray(open(tape, "rb").read())
    if polls is not None:
        struct.pack_into("<I", data, POLLS_OFFSET, polls)
    open(os.path.join(workdir, "haltape.bin"), "wb").write(data)
    count = os.path.join(workdir, "count.txt")
    cmd = [sys.executable, FEED, "--tape", "haltape.bin", "--"] + qemu + [
        "-plugin", f"{plugin},out={count},exclude={exclude[0]:x}-{exclude[1]:x}", "-kernel", os.path.abspath(elf)]
    r = subprocess.run(cmd, cwd=workdir, capture_output=True, timeout=600)
    if r.returncode != 0:
        sys.exit(f"board_footprint: {' '.join(cmd)} exited {r.returncode}: {(r.stdout + r.stderr).decode()[-500:]}")
    stack, est, app, cycles = struct.unpack("<4I", open(os.path.join(workdir, "fwstats.bin"), "rb").read())
    return int(open(count).read().strip()), {"stack": stack, "estimator": est, "app": app, "cycles": cycles}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--elf", required=True)
    ap.add_argument("--plugin", required=True)
    ap.add_argument("--hal-tape", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--size-tool", default="arm-none-eabi-size")
    ap.add_argument("--nm-tool", default="arm-none-eabi-nm")
    ap.add_argument("--polls", type=int, nargs=2, default=[10001, 20001], metavar=("N1", "N2"))
    ap.add_argument("qemu", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    qemu = a.qemu[1:] if a.qemu[:1] == ["--"] else a.qemu
    for path in (a.elf, a.plugin, a.hal_tape):
        if not os.path.exists(path):
            sys.exit(f"board_footprint: missing {path}")
    text, data, bss = map(int, subprocess.check_output([a.size_tool, a.elf]).decode().splitlines()[1].split()[:3])
    stack_reserved = int(subprocess.check_output([a.size_tool, "-A", a.elf]).decode().split(".stack")[1].split()[0])
    exclude = wait_range(a.nm_tool, a.elf)
    with tempfile.TemporaryDirectory() as tmp:
        i1, s1 = run(qemu, a.plugin, a.elf, a.hal_tape, a.polls[0], os.path.join(tmp, "n1"), exclude)
        i2, s2 = run(qemu, a.plugin, a.elf, a.hal_tape, a.polls[1], os.path.join(tmp, "n2"), exclude)
        whole, sw = run(qemu, a.plugin, a.elf, a.hal_tape, None, os.path.join(tmp, "whole"), exclude)
    cycles = s2["cycles"] - s1["cycles"]
    if cycles <= 0:
        sys.exit(f"board_footprint: no cycle ran between polls {a.polls[0]} and {a.polls[1]}")
    ipc = (i2 - i1) / cycles
    fp = {
        "board": "STM32F405RG (run under QEMU netduinoplus2)",
        "image": os.path.basename(a.elf),
        "text_bytes": text,
        "data_bytes": data,
        "bss_bytes": bss,
        "flash_bytes": text + data,
        "ram_static_bytes": data + bss - stack_reserved,
        "stack_reserved_bytes": stack_reserved,
        "stack_bytes_max": sw["stack"],
        "estimator_state_bytes": sw["estimator"],
        "application_state_bytes": sw["app"],
        "instructions_per_cycle": round(ipc),
        "polls_per_cycle": round((a.polls[1] - a.polls[0]) / cycles, 2),
        "cycles_measured": cycles,
        "instructions_whole_drive": whole,
        "cycles_whole_drive": sw["cycles"],
        "cpu_share_pct_at_1_m_per_s_168_MHz": round(ipc * 100 / 168e6 * 100, 2),
    }
    with open(a.out, "w") as f:
        json.dump(fp, f, indent=2)
        f.write("\n")
    print(json.dumps(fp, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
