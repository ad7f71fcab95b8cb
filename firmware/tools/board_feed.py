#!/usr/bin/env python3
"""Feeds a HAL tape's laser bytes into the STM32F405 board image's USART1 under QEMU.

    board_feed.py --tape haltape.bin [--timeout S] -- qemu-system-arm -M netduinoplus2 ... -kernel fw_board.elf

QEMU runs with USART1 on its standard input and output (`-serial stdio`). Each time the image
sends its request byte 'N' on USART1, the feeder writes the laser bytes of the tape's next poll
that holds any (firmware/apps/fw_replay/fw_replay.hpp reads the same records). The image reads
the tape's times and counts itself, through semihosting, in the working directory.

The exit status is QEMU's (the image's exit code), or 1 when the image asked for more polls
than the tape holds, finished with success after fewer, sent another byte, or went quiet
for --timeout seconds. A tape that ends early is fed as far as it goes: the image reads the
same records and reports the end in its exit code (3).
"""
import argparse
import os
import select
import struct
import subprocess
import sys

HEADER_BYTES = 56  # fw/hal_tape.hpp: "ODHT", version, 13 words (kHalTapeHeaderBytes)
POLLS_OFFSET = 48  # the header's poll count
POLL_BYTES = 18    # time (u64), count A, count B (u32), byte count (u16)


def laser_chunks(path):
    """The laser bytes of each poll that holds any, in the tape's order."""
    data = open(path, "rb").read()
    if len(data) < HEADER_BYTES or data[:4] != b"ODHT":
        sys.exit(f"board_feed: {path}: not a HAL tape")
    (polls,) = struct.unpack_from("<I", data, POLLS_OFFSET)
    chunks, off = [], HEADER_BYTES
    for k in range(polls):
        if off + POLL_BYTES > len(data):
            # The image reads the same records, finds the same end and says so in its exit code.
            print(f"board_feed: {path}: the tape ends at poll {k} of {polls}", file=sys.stderr)
            break
        (n,) = struct.unpack_from("<H", data, off + 16)
        off += POLL_BYTES
        if n:
            chunks.append(data[off:off + n])
        off += n
    return chunks


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tape", required=True)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds without a request before giving up")
    ap.add_argument("qemu", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    cmd = a.qemu[1:] if a.qemu[:1] == ["--"] else a.qemu
    if not cmd:
        ap.error("no QEMU command after --")
    chunks = laser_chunks(a.tape)
    q = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    out_fd, sent, problem = q.stdout.fileno(), 0, None
    try:
        while True:
            ready, _, _ = select.select([out_fd], [], [], a.timeout)
            if not ready:
                problem = f"no request for {a.timeout:g} s after {sent} of {len(chunks)} polls"
                break
            got = os.read(out_fd, 4096)
            if not got:
                break  # the image has exited
            for byte in got:
                if byte != ord("N"):
                    problem = f"byte {byte:#04x} on USART1 where a request was expected"
                elif sent == len(chunks):
                    problem = f"a request beyond the tape's {len(chunks)} polls with laser bytes"
                else:
                    try:
                        q.stdin.write(chunks[sent])
                    except BrokenPipeError:
                        break  # the image has exited
                    sent += 1
                if problem:
                    break
            if problem:
                break
            try:
                q.stdin.flush()
            except BrokenPipeError:
                pass
    finally:
        if problem:
            q.kill()
        try:
            q.stdin.close()
        except BrokenPipeError:
            pass
        rc = q.wait()
    if problem is None and rc == 0 and sent != len(chunks):
        problem = f"the image finished after {sent} of {len(chunks)} polls with laser bytes"
    total = sum(len(c) for c in chunks[:sent])
    print(f"board_feed: {sent} polls' laser bytes ({total} bytes) sent on request; the image exited {rc}")
    if problem:
        print(f"board_feed: {problem}", file=sys.stderr)
        return 1
    return rc if rc >= 0 else 1  # killed by a signal


if __name__ == "__main__":
    sys.exit(main())
