"""carmen_header.py: the header of an odolog written from a CARMEN log (comment lines, the
meta lines that say what was read, chosen and counted, the drive, laser and init records),
from a finished carmen_convert.Converter."""

import math

from carmen_convert import FIX_SIGMA, INIT_SIGMA, ORDER_STEP, TIME_STEP_MIN
from carmen_laser import LASER_PARAMS
from carmen_log import READ_TYPES
from carmen_ticks import TICKS_PER_REV, TRACK_HEADING_RAD, TRACK_POS_M, WHEELBASE_M, WHEEL_RADIUS_M

# The five buildings of ../shared/data/carmen (README.md there): the comment line's title and
# the credit. All five are GMapping-corrected logs distributed by Radish, copied from
# github.com/acschaefer/ple (data/carmen/).
RADISH = "distributed by Radish, the Robotics Data Set Repository"
BUILDINGS = {
    "intel-corrected": ("Intel Research Lab",
                        "recorded by Dirk Haehnel (Intel Research Lab, Seattle); " + RADISH),
    "aces-corrected": ("ACES building, University of Texas at Austin", RADISH),
    "freiburg-079-corrected": ("Building 079, University of Freiburg", RADISH),
    "csail-corrected": ("CSAIL building, MIT", RADISH),
    "orebro-corrected": ("Orebro University", RADISH),
}


def odolog_text(conv, digest, max_scans, name):
    """The whole odolog: the header, then conv's records. name: the source's name (the five
    buildings are credited by it); digest: the SHA-256 of the decompressed source."""
    h = []
    w = h.append
    x, y, th = conv.init
    title, credit = BUILDINGS.get(name, (None, None))
    w("odolog 1")
    if title:
        w(f"# {title} (CARMEN, SLAM-corrected) converted by tools/import/carmen_to_odolog.py")
    else:
        w(f"# CARMEN log {name} (SLAM-corrected) converted by tools/import/carmen_to_odolog.py")
    w("# enc: raw odometry sub-steps turned into the ticks of an equivalent differential drive")
    w("#      (d = 0.33 m, r = 0.0825 m, 4096 ticks/rev; mid-point model; sideways part dropped)")
    if conv.odo.splits:
        w("#      where one arc would leave the ticks off the logged odometry: an arc, then a turn in place")
    if conv.fills:
        w("# (intervals without raw odometry: the corrected pose stands in for it; meta odometry_gaps)")
    w("# truth: SLAM-corrected FLASER poses (a SLAM result, not motion capture)")
    if conv.with_scans:
        w("# scan: the FLASER ranges (nan = no return); no wall records: the map is a separate file")
        w("#       (odoerr map grid-from-carmen + odoerr map import), built from the corrected poses,")
        w("#       so scoring against the truth below is partly circular (shared SLAM errors).")
    else:
        w("# No laser/scan/wall records (use --scans for the laser; the map is a separate file).")
    w(f"meta source carmen {name}")
    if credit:
        w(f"meta credit {credit}; SLAM-corrected copy from github.com/acschaefer/ple "
          f"data/carmen/{name}.log.gz; no separate data licence stated")
    w(f"meta source_sha256 {digest} (decompressed text)")
    w("meta importer tools/import/carmen_to_odolog.py")
    w(f"meta scans {conv.scans}{'' if max_scans is None else f' (--max-scans {max_scans})'}; "
      f"odom sub-steps {conv.odo.substeps} ({conv.after_last} after the last scan); "
      f"{conv.prefix_odom} ODOM lines before the first scan dropped")
    if conv.order:
        # docs/odolog.md, meta time_base: the stamps order the records, they do not measure
        # time (the reader's plausibility rule then uses the log's own increments)
        w("meta time_base order")
        w(f"meta time synthetic t = {ORDER_STEP:g} s per line used, in file order (--time order: the log's "
          f"time stamps are not used); {conv.stamps} lines")
    else:
        w(f"meta time synthetic t = max(ipc_timestamp, previous t + {TIME_STEP_MIN:g} s) in file order; "
          f"{conv.backwards} stamps went backwards and {conv.repeats} repeated the previous one; "
          f"{conv.moved} of {conv.stamps} written times differ from their stamp, by at most {conv.max_shift:.3f} s")
    w(f"meta odometry path {conv.odo.path:.3f} m, rotation {conv.odo.rot:.3f} rad, "
      f"largest sub-step rotation {conv.odo.max_dth:.4f} rad, "
      f"dropped sideways motion {conv.odo.side_sum:.4f} m in all (at most {conv.odo.side_max:.4f} m per sub-step)")
    if conv.fix_every > 0:
        w(f"meta pose_fixes corrected pose every {conv.fix_every} scans, "
          f"sigma {FIX_SIGMA[0]:g} m {FIX_SIGMA[2]:g} rad")
    else:
        w("meta pose_fixes none")
    if conv.with_scans:
        w(f"meta scans_written {conv.scans} scans of {conv.beams} beams: {conv.returns} returns, "
          f"{conv.no_returns} no-return beams written as nan")
    # what was read, what was chosen and from where
    kinds = [k for k in conv.counts if k != "#"]
    read = [k for k in kinds if k in READ_TYPES]
    skipped = [k for k in kinds if k not in READ_TYPES]
    w("meta carmen_messages " + ", ".join(f"{k} {conv.counts[k]}" for k in kinds) +
      f"; read: {' '.join(read) or 'none'}; skipped (counted only): {' '.join(skipped) or 'none'}"
      + (f"; {conv.counts['#']} comment lines" if "#" in conv.counts else ""))
    if conv.declared is not None:
        w("meta carmen_formats_declared " + (" ".join(conv.declared) or "(none)") +
          " (the log's '# message formats defined' line)")
    pr = sorted(conv.params.values(), key=lambda q: q.no)
    w("meta carmen_params_read " + ("; ".join(f"{q.name} {q.text} (line {q.no})" for q in pr)
                                    if pr else "none of " + " ".join(LASER_PARAMS)))
    if not conv.order:
        w(f"meta time_stamps ipc_timestamp, or logger_timestamp where that is 0 or not usable: "
          f"{conv.from_logger} of {conv.stamps} lines used took the logger's")
    w("meta pairing each FLASER with the raw ODOM line of its time " +
      ("(--time order: the last one before it since the previous scan's anchor)" if conv.order else
       "stamp (before it, or after it before its anchor)"))
    w(f"meta odometry_gaps {conv.fills} intervals without raw odometry" +
      (" filled from the FLASER's own odom fields, i.e. the corrected pose (--missing-odometry flaser): "
       "their ticks carry no odometry error" if conv.fills else ""))
    w(f"meta odometry_split {conv.odo.splits} of {conv.odo.substeps} sub-steps would have left the ticks more than "
      f"{TRACK_POS_M:g} m or {TRACK_HEADING_RAD:g} rad from the logged odometry as one arc (their sideways "
      f"parts: {conv.odo.split_side:.4f} m in all) and were written as an arc to the logged end point and a turn "
      f"in place (at most {conv.odo.split_turn:.4f} rad)")
    lo, hi = conv.heading_range
    w(f"meta headings differenced modulo 2 pi; the log's headings used run from {lo:g} to {hi:g} rad "
      f"({'not ' if lo <= -math.pi or hi > math.pi else ''}all within (-pi, pi]), written as they are")
    if conv.with_scans:
        for m in conv.laser_meta:
            w("meta " + m)
        if conv.pile_up:
            w("meta " + conv.pile_up)
    for m in conv.choice_meta:
        w(m)
    w("drive diff")
    w(f"param wheel_radius_m {WHEEL_RADIUS_M:g}")
    w(f"param ticks_per_rev {TICKS_PER_REV}")
    w(f"param wheelbase_m {WHEELBASE_M:g}")
    if conv.with_scans:
        start, step, rmax, mount = conv.laser
        w(f"laser {conv.beams} {start:.9f} {step:.9f} {rmax:g} {conv.range_sigma:g} "
          f"{mount[0]:g} {mount[1]:g} {mount[2]:g}")
    w(f"init {x:.6f} {y:.6f} {th:.6f} {INIT_SIGMA[0]:g} {INIT_SIGMA[1]:g} {INIT_SIGMA[2]:g}")
    return "\n".join(h + conv.body) + "\n"
