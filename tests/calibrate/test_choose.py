#!/usr/bin/env python3
"""The range sigma `odoerr calibrate` chooses (tools/calibrate/choose.py): the candidates
(multiples of the residual sigma, clipped, near-duplicates dropped), the residual sigma
itself from an innovations.csv, a track's quality from its tracking.csv, and the rule that
keeps one (never lost; the best mean fit; within the tie margin the smaller sigma; every
one lost: the longest kept). Each check can fail: it states the value the rule must give."""
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools", "calibrate"))
import choose  # noqa: E402


def q(fit, lost=False, episodes=0):
    return {"fit_mean": fit, "lost": lost, "lost_episodes": episodes, "scans": 10}


def main():
    fails = []

    def check(what, got, want):
        ok = got == want if not isinstance(want, float) else got is not None and abs(got - want) < 1e-9
        print(("ok   " if ok else "FAIL ") + f"{what}: {got!r}" + ("" if ok else f" (expected {want!r})"))
        if not ok:
            fails.append(what)

    # candidates
    check("candidates of 0.04 m", [round(v, 4) for v in choose.candidates(0.04)], [0.04, 0.06, 0.08, 0.12])
    check("candidates of 0.01 m: clipped to 0.03, the duplicates dropped",
          [round(v, 4) for v in choose.candidates(0.01)], [0.03])
    check("candidates of 0.15 m: 0.225, then 0.30 twice", [round(v, 4) for v in choose.candidates(0.15)],
          [0.15, 0.225, 0.3])
    # the rule
    check("the best mean fit wins", choose.best([(0.04, q(0.70)), (0.06, q(0.85)), (0.08, q(0.80))])[0], 0.06)
    check("within the tie margin the smaller sigma", choose.best([(0.04, q(0.845)), (0.06, q(0.85))])[0], 0.04)
    check("just past the tie margin the better fit",
          choose.best([(0.04, q(0.85 - choose.FIT_TIE - 0.001)), (0.06, q(0.85))])[0], 0.06)
    check("a track lost at its end is not kept, however it fits",
          choose.best([(0.04, q(0.95, lost=True)), (0.06, q(0.60))])[0], 0.06)
    far = dict(q(0.5, lost=True), scans=40)
    check("all lost: the one that kept the track longest",
          choose.best([(0.04, far), (0.06, q(0.9, lost=True))])[0], 0.04)
    check("the first pass lost: the whole span", choose.candidates(0.3, first_pass_tracked=False),
          list(choose.SIGMA_SPAN))
    check("no fit at all: none", choose.best([(0.04, q(None))]), None)

    with tempfile.TemporaryDirectory() as d:
        # residual sigma: only used or gated beams within 1 m count; fewer than 100: none
        inn = os.path.join(d, "innovations.csv")
        with open(inn, "w") as f:
            f.write("t,beam,status,measured,predicted,innovation,variance,nis\n")
            for i in range(150):
                f.write(f"0,{i},used,1,1,{0.01 * (1 if i % 2 else -1) * (1 + i % 3)},0.001,1\n")
            f.write("0,0,used,1,1,5.0,0.001,1\n0,0,skipped,1,1,0.5,0.001,1\n0,0,gated,1,1,,,\n")
        sig, n = choose.residual_sigma(inn)
        check("residual sigma: the beams counted", n, 150)
        check("residual sigma: 1.4826 x the median |innovation|", sig, 1.4826 * 0.02)
        with open(inn, "w") as f:
            f.write("t,beam,status,measured,predicted,innovation,variance,nis\n" + "0,0,used,1,1,0.01,0.001,1\n" * 99)
        check("residual sigma from 99 beams: none", choose.residual_sigma(inn), (None, 99))
        # track quality: the mean of the finite fits; lost and its episodes from replay.json
        with open(os.path.join(d, "tracking.csv"), "w") as f:
            f.write("t,x,y,theta,fit,state\n0,0,0,0,0.9,tracked\n1,0,0,0,0.5,lost\n2,0,0,0,nan,lost\n"
                    "3,0,0,0,,tracked\n4,0,0,0,0.7,tracked\n")
        tq = choose.track_quality(d, {"tracking": {"lost": True, "lost_episodes": 2}})
        check("track quality: mean fit of the finite fits", tq["fit_mean"], 0.7)
        check("track quality: scans with a fit", tq["scans"], 3)
        check("track quality: lost and episodes", (tq["lost"], tq["lost_episodes"]), (True, 2))
    print(f"{len(fails)} failed" if fails else "all passed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
