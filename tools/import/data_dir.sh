# data_dir.sh: where the real data is, for the shell scripts (sourced, not run). The rule
# (docs/real-data.md, "Where the data comes from"; the same in import_common.py):
# - the data folder is $ODOERR_DATA when set, else <repository root>/../shared/data;
# - what a test needs and the data folder lacks is taken from the sample in the repository,
#   tests/data (the same layout: optiodom-diff/, ros-maps/), when the sample has it;
# - what neither has (the CARMEN logs are never in the sample) makes the test skip, exit 77,
#   with a message naming ODOERR_DATA.
# Defines ODOERR_ROOT, ODOERR_DATA_DIR, ODOERR_SAMPLE_DIR and the functions below.
ODOERR_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
ODOERR_DATA_DIR="${ODOERR_DATA:-$(dirname "$ODOERR_ROOT")/shared/data}"
ODOERR_SAMPLE_DIR="$ODOERR_ROOT/tests/data"

# odoerr_data_find REL: prints the folder (data folder first, then the sample) that holds
# REL, a file or folder path relative to it; status 1 (nothing printed) when neither does.
odoerr_data_find() {
  local d
  for d in "$ODOERR_DATA_DIR" "$ODOERR_SAMPLE_DIR"; do
    if [ -e "$d/$1" ]; then (cd "$d" && pwd); return 0; fi
  done
  return 1
}

# odoerr_data_full REL: as odoerr_data_find, in the data folder alone (for what needs more
# than the sample).
odoerr_data_full() {
  if [ -e "$ODOERR_DATA_DIR/$1" ]; then (cd "$ODOERR_DATA_DIR" && pwd); return 0; fi
  return 1
}

# odoerr_data_where: "the full data (FOLDER)" or "the sample in the repository (FOLDER)",
# for a script's first line of output.
odoerr_data_where() {
  if [ "$1" = "$(cd "$ODOERR_SAMPLE_DIR" 2>/dev/null && pwd)" ]; then
    echo "the sample in the repository ($1)"
  else
    echo "the full data ($1)"
  fi
}

# odoerr_data_skip_message WHAT REL: the line saying that WHAT, which needs REL, is skipped.
odoerr_data_skip_message() {
  echo "skipped: $1: $2 is absent from the data folder $ODOERR_DATA_DIR" \
       "(set ODOERR_DATA to a folder holding it; default: ../shared/data from the repository root)"
}

# odoerr_data_skip WHAT REL: prints that line and exits 77 (ctest's SKIP_RETURN_CODE).
odoerr_data_skip() {
  odoerr_data_skip_message "$1" "$2"
  exit 77
}
