"""The parts of the fixture that discovery, the change-point scan and --with auto add to what
`odoerr diagnose` writes: diagnose.json's "unexplained", "change_points", "auto", the
ranking rows' "explains" / "not_named_because", the nested tests (per_beam, pose_correction,
of_observables), and DIR/discovery_motion.csv / discovery_beam.csv.

Planted: the robot drifts toward +x in the world frame (world/world_x/abs_ds = 0.0115) and the
scanner's beam angles are scaled (beam/range/alpha_angle_sens = 0.0014); the drive parameters
change once, at 60 % of the drive. Used by make_fixture.py; only numpy."""
import os

import numpy as np

MOTION = ("world", "world_x", "abs_ds", 0.0115, 0.0007,
          "the robot drifts 1.15 cm per m of travel toward +x in the world frame, whatever its heading "
          "(a slope, a floor that pushes) (± 0.0007)", "feature:abs_ds@world_x")
BEAM = ("beam", "range", "alpha_angle_sens", 0.0014, 0.000044,
        "the beam angles are scaled by 1 +0.0014: a beam-angle scale error of the scanner (± 4.4e-05)",
        "feature:alpha_angle_sens")
BASELINE_ONLY = ("robot", "cross", "v_w", 0.0021, 0.0004,
                 "the robot slides 2.10 mm sideways (left +) per m of travel per rad/s of turn rate (± 0.0004)",
                 "feature:v_w@cross")


def feature(f):
    frame, comp, name, coef, sigma, words, with_ = f
    return {"name": name, "frame": frame, "component": comp, "coef": coef, "sigma": sigma, "words": words,
            "with": with_}


def add_tests_extras(tests, rng, n_beams):
    """The nested entries of "tests" that the report must summarise, not dump."""
    i = np.arange(n_beams)
    t = 4.0 * (i / max(n_beams - 1, 1) - 0.5) + rng.normal(0, 1, n_beams)
    tests["nis_mean_uncapped"] = round(tests["nis_mean"] * 7.3, 4)
    tests["per_beam"] = [{"beam": int(b), "count": 2390.0, "mean_norm": round(float(tb) * 0.05, 5),
                          "rms_norm": round(float(abs(rng.normal(3, 1))), 4), "t": round(float(tb), 4)}
                         for b, tb in zip(i, t)]
    tests["per_beam_max_abs_t"] = round(float(np.max(np.abs(t))), 4)
    tests["pose_correction"] = {"along_m": {"mean": -6.8e-05, "rms": 0.00235, "t": -1.42},
                                "cross_m": {"mean": 1.8e-04, "rms": 0.0004, "t": 6.1},
                                "heading_rad": {"mean": 7.5e-05, "rms": 0.0089, "t": 0.41}}
    tests["of_observables"] = {"updates": 2389, "z1": {"mean_norm": 0.016, "mean_square_norm": 0.968}, "z2": None}
    tests["nees_pose_dof"] = 3
    tests["nis_consistent"] = False


def write_discovery_csv(path, t, y, fit, terms):
    """terms: [(name, column, partial)]."""
    header = "t,row,y,fit" + "".join(f",{n},partial_{n}" for n, _, _ in terms)
    with open(path, "w") as f:
        f.write(header + "\n")
        for k in range(len(t)):
            f.write(f"{t[k]:.3f},{k},{y[k]:.5g},{fit[k]:.5g}" + "".join(f",{c[k]:.5g},{p[k]:.5g}" for _, c, p in terms)
                    + "\n")


def add_discovery(doc, outdir, rng, t_end, dist_end):
    """Adds the keys to doc (the diagnose.json object) and writes the two CSVs."""
    # Motion: 0.5 s segments after the 10 s warm-up, three rows (x, y, heading) each.
    seg_t = np.arange(10.5, max(t_end, 12.0), 0.5)
    t = np.repeat(seg_t, 3)
    comp = np.tile(np.arange(3), len(seg_t))
    travel = np.abs(rng.normal(25.0, 18.0, len(t)))                  # standardised column
    col = np.where(comp == 0, travel * np.abs(np.cos(seg_t.repeat(3) / 7.0)), 0.0)
    nuis = rng.normal(0, 0.05, len(t))
    coef = MOTION[3]
    y = coef * col + nuis + rng.normal(0, 1, len(t))
    fit = coef * col + nuis
    name = "/".join(MOTION[:3])
    write_discovery_csv(os.path.join(outdir, "discovery_motion.csv"), t, y, fit, [(name, col, y - nuis)])
    # Beams: every 8th beam.
    nb = 6000
    tb = np.sort(rng.uniform(10.0, max(t_end, 12.0), nb))
    colb = rng.normal(0, 300.0, nb)
    yb = BEAM[3] * colb + rng.normal(0, 1, nb)
    write_discovery_csv(os.path.join(outdir, "discovery_beam.csv"), tb, yb, BEAM[3] * colb,
                        [("/".join(BEAM[:3]), colb, yb)])

    named = [r["effect"] for r in doc["ranking"] if r.get("significant")]
    doc["unexplained"] = {
        "significant": True, "explained_fraction": 0.41 if named else 0.0,
        "features": [feature(MOTION), feature(BEAM)],
        "motion": {"segments": len(seg_t), "rows": len(t), "sse_cv_model": 1521.9, "sse_cv_features": 1391.4,
                   "features_explain": 0.0858, "segment_s": 0.5},
        "beam": {"beams": nb * 8, "rows": nb * 8, "sse_cv_model": 83704.8, "sse_cv_features": 74712.7,
                 "features_explain": 0.107},
        "baseline_features": [feature(MOTION), feature(BEAM), feature(BASELINE_ONLY)],
        "note": "the named effects leave part of the misfit: these features describe the rest"}
    tc = round(0.6 * t_end, 1)
    doc["change_points"] = [{
        "t": tc, "t_lo": round(tc - 0.1 * t_end, 1), "t_hi": round(tc + 0.05 * t_end, 1),
        "what": "the drive parameters change: the right wheel's travel scale -2.12 %, the left wheel's travel "
                "scale +0.03 %, the turn scale +0.74 %",
        "statistic": 41.57, "critical_0.1pct": 24.21, "residual": "motion", "remains_with_named": True}]
    for r in doc["ranking"]:
        if r.get("significant"):
            r["explains"] = {"motion": 0.62, "beam": 0.35, "total": 0.41}
            r["not_named_because"] = None
    for r in doc["ranking"]:
        if not r.get("significant") and r["effect"] == "scan_latency":
            r["explains"] = {"motion": 0.08, "beam": None, "total": 0.08}
            r["not_named_because"] = ("it explains 8 % of the misfit the residuals show (motion and beams "
                                      "together); an effect of the right form explains most of it")

    def paired(zp, zn, zs, better):
        q = lambda z: {"blocks": 86, "blocks_better": better, "change_mean": -0.01, "change_z": z}
        return {"nis": q(zs), "nll": q(zn), "pose_err_m": q(zp)}

    def held(with_, pb, pa, nb_, na):
        return {"with": [with_], "folds": 4, "folds_failed": [3],
                "before": {"nis_mean": 1.25, "nll_mean": nb_, "innovation_rms_m": 0.0117, "pose_rmse_m": pb,
                           "heading_rmse_rad": 0.026},
                "after": {"nis_mean": 1.12, "nll_mean": na, "innovation_rms_m": 0.0115, "pose_rmse_m": pa,
                          "heading_rmse_rad": 0.025}}
    s1 = MOTION[6]
    s2 = BEAM[6]
    doc["auto"] = {
        "steps": [
            {"added": s1, "heldout": held(s1, 0.0214, 0.0122, -1.187, -1.221), "paired": paired(-9.6, -5.6, -5.3, 75),
             "score_z": -9.6, "estimate": {"feature_motion": [0.0121]}, "explained_fraction": 0.55,
             "left": [feature(BEAM)]},
            {"added": s2, "heldout": held(s2, 0.0122, 0.0101, -1.221, -1.262), "paired": paired(-3.1, -6.2, -4.0, 61),
             "score_z": -3.1, "estimate": {"feature_range": [0.00141, 0.0, 0.0, 0.0]}, "explained_fraction": 0.97,
             "left": []}],
        "final_with": [s1, s2],
        "tried": [{"step": 0, "added": s1, "paired": paired(-9.6, -5.6, -5.3, 75), "kept": True},
                  {"step": 0, "added": "turn_slip", "paired": paired(-0.4, 0.3, -0.2, 44), "kept": False},
                  {"step": 1, "added": s2, "paired": paired(-3.1, -6.2, -4.0, 61), "kept": True},
                  {"step": 2, "added": "laser_mount_yaw", "paired": paired(0.8, 1.1, 0.2, 38), "kept": False}],
        "rule": "a step is kept when its held-out pose error (with truth; else, or when it adds only noise "
                "effects, the NLL) falls with paired z <= -2, the strongest fall first; candidates: the best named catalogue effect, and the features "
                "the residuals still depend on"}
