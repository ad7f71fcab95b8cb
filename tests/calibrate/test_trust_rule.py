#!/usr/bin/env python3
"""The trust rule of `odoerr calibrate` (tools/calibrate/odoerr_calibrate.py, trust()), clause
by clause: each case breaks exactly one clause of a result that is otherwise trusted, and
must come out NOT trusted with that clause's reason; the unbroken result must be trusted."""
import copy
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "calibrate"))
import odoerr_calibrate as oc  # noqa: E402

GOOD = {"tracking_first_half": {"lost": False},
        "rpe_5m_second_half": {"nominal": {"trans_m": 0.745, "rot_rad": 0.326},
                               "calibrated": {"trans_m": 0.276, "rot_rad": 0.079}},
        "growth": {"ratio_observed_to_predicted": 0.95}}
QUARTERS = {"disagreement_sigma": 1.0, "worst": "delta_d"}


def case(edit, raw=0.9, quarters=QUARTERS):
    r = copy.deepcopy(GOOD)
    edit(r)
    return oc.trust(r, quarters, raw)


def main():
    fails = 0

    def check(got, trusted, needle, what):
        nonlocal fails
        ok = got[0] == trusted and needle in got[1]
        print(("ok   " if ok else "FAIL ") + f"{what}: {'trusted' if got[0] else 'NOT trusted'}: {got[1]}")
        fails += not ok

    check(case(lambda r: None), True, "falls to x0.37", "the unbroken result")
    check(case(lambda r: r["tracking_first_half"].update(lost=True)), False, "lost", "a lost first half")
    check(case(lambda r: r["tracking_first_half"].update(pose_rmse_at_truth_m=2.15)), False, "2.15 m RMS off",
          "a first half 2.15 m off its reference poses")
    check(case(lambda r: None, raw=0.07), False, "7 % of the log's scan intervals", "7 % raw odometry")
    check(case(lambda r: r["rpe_5m_second_half"].update(calibrated=None)), False, "no 5 m segment",
          "no check segment")
    check(case(lambda r: r["rpe_5m_second_half"]["calibrated"].update(trans_m=0.8)), False, "worse than nominal",
          "translation 7 % worse")
    check(case(lambda r: r["rpe_5m_second_half"]["calibrated"].update(trans_m=0.76, rot_rad=0.33)), False,
          "lowers neither", "translation and rotation 2 % and 1 % worse")
    check(case(lambda r: r["growth"].update(ratio_observed_to_predicted=3.28)), False, "3.28x off",
          "growth 3.28x the predicted")
    check(case(lambda r: r["growth"].update(ratio_observed_to_predicted=0.6)), False, "0.60x off",
          "growth 0.6x the predicted")
    check(case(lambda r: r["growth"].pop("ratio_observed_to_predicted")), False, "could not be predicted",
          "no growth predicted")
    check(case(lambda r: None, quarters={"disagreement_sigma": 3.4, "worst": "delta_d"}), True, "3.4 sigma apart",
          "quarters 3.4 sigma apart: a note, still trusted")
    print(f"\n{'all checks passed' if fails == 0 else f'{fails} check(s) failed'}")
    sys.exit(1 if fails else 0)


if __name__ == "__main__":
    main()
