"""What the odolog importers share: the input error, the atomic write, a one-line argument
parser, the entry point, and where the real data is. Standard library only."""
import argparse
import gzip
import math
import os
import zlib
import re
import sys

# a plain decimal number (no inf, nan, hex or underscores)
NUMBER_RE = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")


# Where the real data is (docs/real-data.md, "Where the data comes from"; the same rule as
# data_dir.sh for the shell scripts): the data folder is $ODOERR_DATA when set, else
# <repository root>/../shared/data; what the data folder lacks is taken from the sample in
# the repository, tests/data (the same layout), when the sample has it.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE_DIR = os.path.join(ROOT, "tests", "data")
# The OptiOdom data set's path types (its folders), in the order the reports list them.
OPTIODOM_PATH_TYPES = ("circular", "square", "ivanjko")


def data_dir():
    """The data folder: $ODOERR_DATA when set (and not empty), else ../shared/data from the
    repository root."""
    return os.environ.get("ODOERR_DATA") or os.path.normpath(os.path.join(ROOT, "..", "shared", "data"))


def find_data(rel, sample=True):
    """The folder holding rel (a path relative to it): the data folder, else (sample=True)
    tests/data; None when neither has it."""
    for d in (data_dir(), SAMPLE_DIR) if sample else (data_dir(),):
        if os.path.exists(os.path.join(d, rel)):
            return d
    return None


def skip_message(what, rel):
    """The line a script prints before exiting 77 when rel (relative to the data folder, or a
    whole path) is absent."""
    where = "" if os.path.isabs(rel) else " from the data folder %s" % data_dir()
    return ("skipped: %s: %s is absent%s (set ODOERR_DATA to a folder holding it; "
            "default: ../shared/data from the repository root)" % (what, rel, where))


class InputError(Exception):
    """A malformed input; the message already names FILE:LINE. `fix`, when set, is the
    (option, value) that reads such a log instead of refusing it (carmen_to_odolog.py
    --auto takes it and says so)."""

    def __init__(self, message, fix=None):
        super().__init__(message)
        self.fix = fix


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


def decoded_lines(lines, path, encoding, name):
    """(no, where, text) for each line of `lines` (bytes, split on b"\n"), numbered from 1, where
    = "PATH:NO"; a line that is not `encoding` is an InputError "PATH:NO: the line is not NAME"."""
    for no, raw in enumerate(lines, start=1):
        where = f"{path}:{no}"
        try:
            yield no, where, raw.decode(encoding)
        except UnicodeDecodeError:
            raise InputError(f"{where}: the line is not {name}") from None


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


def with_map_walls(src, odomap, dst):
    """Writes the odolog src to dst with the line map's segments (`odoerr map import`'s
    .odomap) as its wall records, before the first data record, in place of any walls src
    had: what evaluate and diagnose read a map from."""
    walls = []
    with open(odomap) as m:
        for line in m:
            if line.startswith(("segment ", "wall ")):
                walls.append("wall " + " ".join(line.split()[1:5]) + "\n")
    with open(src) as f, open(dst, "w") as g:
        done = False
        for line in f:
            if not done and line.startswith(("enc ", "scan ", "pose ", "truth ")):
                g.writelines(walls)
                done = True
            if not line.startswith("wall "):
                g.write(line)
