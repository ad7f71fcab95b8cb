"""What the odolog importers share: the input error, the atomic write, a one-line argument
parser and the entry point. Standard library only."""
import argparse
import gzip
import math
import os
import zlib
import re
import sys

# a plain decimal number (no inf, nan, hex or underscores)
NUMBER_RE = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")


class InputError(Exception):
    """A malformed input; the message already names FILE:LINE."""


def parse_number(tok, where, what):
    """tok as a finite float; InputError naming `where` (FILE:LINE) and `what` otherwise."""
    if not NUMBER_RE.match(tok):
        raise InputError(f"{where}: {what}: '{tok}' is not a decimal number")
    v = float(tok)
    if not math.isfinite(v):
        raise InputError(f"{where}: {what}: '{tok}' is not a finite number")
    return v


def read_lines(path):
    """The lines of a UTF-8 text file; InputError naming the file when it cannot be read."""
    try:
        with open(path, "r", encoding="utf-8") as f:
            return f.read().split("\n")
    except OSError as e:
        raise InputError(f"{path}: cannot read: {e.strerror or e}") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text") from None


def read_bytes(path):
    """The bytes of a file, gunzipped when it is gzip data; InputError naming the file."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise InputError(f"{path}: cannot read: {e.strerror or e}") from None
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as e:
            raise InputError(f"{path}: not a readable gzip file: {e}") from None
    return data


def write_atomic(path, text):
    """Writes text to path through a temporary file, so a failed write leaves no half file."""
    d = os.path.dirname(os.path.abspath(path))
    tmp = os.path.join(d, f".{os.path.basename(path)}.tmp{os.getpid()}")
    try:
        with open(tmp, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
        os.replace(tmp, path)
    except OSError as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise InputError(f"{path}: cannot write: {e.strerror or e}") from None


class Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit 2 (argparse's own convention)
        sys.stderr.write(f"{self.prog}: {message}\n")
        sys.exit(2)


def run(main):
    """The importers' entry point: main's exit code; 130 on Ctrl-C."""
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(130)
