#include "heldout.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

namespace odoerr::sim::diag {

namespace {
using json = nlohmann::ordered_json;
constexpr double kLostS = 10.0;  // a fit that fused scans with under a quarter of their beams this long lost the robot
                                 // (a model that misfits loses beams for a few seconds in a turn and recovers)
}  // namespace

template <typename En>
HeldoutResult compareModels(const En& en, const std::vector<int>& before_idx, const En& en_after,
                            const std::vector<int>& after_idx, const std::vector<std::string>& names,
                            const DiagnoseOptions& opt, const std::vector<std::uint8_t>* leave_out) {
  using RunSpec = typename En::RunSpec;
  using RunOut = typename En::RunOut;
  using Drive = typename En::Drive;
  constexpr int kD = En::kD;
  constexpr int kE = En::kE;
  const auto& fx = en.effects();
  const int folds = en.folds();
  std::vector<RunOut> fit_before(folds), fit_after(folds), ev_before(folds), ev_after(folds);
  std::vector<RunSpec> fit_before_spec(folds), fit_after_spec(folds);
  std::vector<std::function<void()>> tasks;
  // A model's fit on fold f's kept data: the drive parameters, K and the model's effects
  // free; a noise effect cannot be augmented: its fit is the profile over the kept data.
  auto fitSpec = [&](const En& eng, const std::vector<int>& effects, int f) {
    RunSpec fit = eng.nominalSpec(eng.initialK(), true);
    fit.mode = Mode::kFit;
    fit.fold = f;
    for (int e : effects)
      if (fx[e].kind != EffectKind::kNoise) eng.freeEffect(&fit, e);
    for (int e : effects) {
      if (fx[e].kind != EffectKind::kNoise) continue;
      double best = -std::numeric_limits<double>::infinity(), best_q = 0;
      for (double g : kNoiseGrid) {
        RunSpec s = fit;
        s.eff_val[fx[e].offset - kE] = g * fx[e].ref[0];
        const RunOut r = eng.run(s);  // scored on the kept data only
        if (r.loglik > best) {
          best = r.loglik;
          best_q = g * fx[e].ref[0];
        }
      }
      fit.eff_val[fx[e].offset - kE] = best_q;
    }
    return fit;
  };
  std::vector<int> with_idx;  // the after model's effects the before model lacks: their estimates are reported
  for (int e : after_idx)
    if (std::find(before_idx.begin(), before_idx.end(), e) == before_idx.end()) with_idx.push_back(e);
  for (int f = 0; f < folds; ++f) {
    tasks.push_back([&, f] {
      fit_before_spec[f] = fitSpec(en, before_idx, f);
      fit_before[f] = en.run(fit_before_spec[f]);
    });
    tasks.push_back([&, f] {
      fit_after_spec[f] = fitSpec(en_after, after_idx, f);
      fit_after[f] = en_after.run(fit_after_spec[f]);
    });
  }
  runParallel(tasks, opt.threads);
  tasks.clear();
  // Evaluation: everything the fold's fit estimated is held.
  auto evalSpec = [&](const En& eng, const RunOut& fit, const RunSpec& fit_spec, const std::vector<int>& effects,
                      int fold) {
    RunSpec ev = eng.nominalSpec(fit.k, false);
    ev.mode = Mode::kEval;
    ev.fold = fold;
    ev.hold_drive = true;
    ev.drive_val = fit.x.template segment<Drive::kParams>(kD);
    for (int e : effects)
      for (int i = 0; i < fx[e].n; ++i) {
        const int k = fx[e].offset + i;
        ev.eff_val[k - kE] = fx[e].kind == EffectKind::kNoise ? fit_spec.eff_val[k - kE] : fit.x[k];
      }
    return ev;
  };
  for (int f = 0; f < folds; ++f) {
    tasks.push_back([&, f] { ev_before[f] = en.run(evalSpec(en, fit_before[f], fit_before_spec[f], before_idx, f)); });
    tasks.push_back([&, f] {
      ev_after[f] = en_after.run(evalSpec(en_after, fit_after[f], fit_after_spec[f], after_idx, f));
    });
  }
  runParallel(tasks, opt.threads);
  tasks.clear();

  HeldoutResult res;
  std::vector<HeldScan>& held_before = res.before;
  std::vector<HeldScan>& held_after = res.after;
  // Before and after over the beams both predicted (matched by key), fold by fold.
  struct Sums {
    double nis = 0, nll = 0, sq = 0, pos_sq = 0, head_sq = 0;
    long n = 0, nsq = 0, nt = 0;
  } before, after;
  using PerScan = std::vector<std::array<double, 3>>;  // NIS sum, NLL sum, beams
  auto take = [](const HeldBeam& h, Sums* sm, PerScan* per) {
    sm->nis += h.nis;
    sm->nll += h.nll;
    ++sm->n;
    if (h.inside) {
      sm->sq += h.nu2;
      ++sm->nsq;
    }
    auto& q = (*per)[static_cast<std::size_t>(h.scan)];
    q[0] += h.nis;
    q[1] += h.nll;
    q[2] += 1;
  };
  auto scans = [](const RunOut& r, const PerScan& per, Sums* sm, std::vector<HeldScan>* dst) {
    for (std::size_t k = 0; k < r.ho_scans.size(); ++k) {
      if (per[k][2] == 0) continue;
      dst->push_back({r.ho_scans[k].t, per[k][0] / per[k][2], per[k][1] / per[k][2], r.ho_scans[k].pose_err});
    }
    sm->pos_sq += r.ho_pos_sq;
    sm->head_sq += r.ho_head_sq;
    sm->nt += r.ho_nt;
  };
  long n_left_out = 0;  // beam predictions in both runs left out (map regions)
  auto common = [&](RunOut& rb, RunOut& ra) {
    auto byKey = [](const HeldBeam& x, const HeldBeam& y) { return x.key < y.key; };
    std::sort(rb.ho_beams.begin(), rb.ho_beams.end(), byKey);
    std::sort(ra.ho_beams.begin(), ra.ho_beams.end(), byKey);
    PerScan pb(rb.ho_scans.size(), {0, 0, 0}), pa(ra.ho_scans.size(), {0, 0, 0});
    for (std::size_t i = 0, j = 0; i < rb.ho_beams.size() && j < ra.ho_beams.size();) {
      const HeldBeam &x = rb.ho_beams[i], &y = ra.ho_beams[j];
      if (x.key < y.key) {
        ++i;
      } else if (y.key < x.key) {
        ++j;
      } else {
        const bool left_out = leave_out != nullptr && x.key >= 0 &&
                              static_cast<std::size_t>(x.key) < leave_out->size() &&
                              (*leave_out)[static_cast<std::size_t>(x.key)] != 0;
        if (x.ok && y.ok && !left_out) {
          take(x, &before, &pb);
          take(y, &after, &pa);
        } else if (left_out) {
          ++n_left_out;
        }
        ++i;
        ++j;
      }
    }
    scans(rb, pb, &before, &held_before);
    scans(ra, pa, &after, &held_after);
  };
  // A fold whose fit lost the robot (dead-reckoning through a held-out block) has no
  // meaningful parameters: it is left out of both sides and reported.
  json fits = json::array(), failed = json::array();
  for (int f = 0; f < folds; ++f) {
    json est_after = json::object();
    for (int e : with_idx) {
      std::vector<double> v;
      for (int i = 0; i < fx[e].n; ++i) {
        const int k = fx[e].offset + i;
        v.push_back(fx[e].kind == EffectKind::kNoise ? fit_after_spec[f].eff_val[k - kE] : fit_after[f].x[k]);
      }
      est_after[fx[e].name] = v;
    }
    const bool ok = fit_before[f].lost_s < kLostS && fit_after[f].lost_s < kLostS;
    fits.push_back({{"fold", f}, {"used", ok}, {"lost_s_before", fit_before[f].lost_s},
                    {"lost_s_after", fit_after[f].lost_s}, {"after_estimate", est_after}});
    if (!ok) {
      failed.push_back(f);
      continue;
    }
    common(ev_before[f], ev_after[f]);
  }
  auto byTime = [](const HeldScan& a, const HeldScan& b) { return a.t < b.t; };
  std::sort(held_before.begin(), held_before.end(), byTime);
  std::sort(held_after.begin(), held_after.end(), byTime);
  auto metrics = [](const Sums& r) {
    json m;
    m["nis_mean"] = r.n > 0 ? json(r.nis / double(r.n)) : json(nullptr);
    m["nll_mean"] = r.n > 0 ? json(r.nll / double(r.n)) : json(nullptr);
    m["innovation_rms_m"] = r.nsq > 0 ? json(std::sqrt(r.sq / double(r.nsq))) : json(nullptr);
    m["pose_rmse_m"] = r.nt > 0 ? json(std::sqrt(r.pos_sq / double(r.nt))) : json(nullptr);
    m["heading_rmse_rad"] = r.nt > 0 ? json(std::sqrt(r.head_sq / double(r.nt))) : json(nullptr);
    return m;
  };
  // Paired by block: each block's mean after minus before, of the NIS, the NLL and the pose
  // error. A consistent change over the blocks (not one lucky block) is what an effect
  // that is really there gives: z is the mean change over its standard error.
  const auto& bl = en.blocks();
  auto paired = [&](double HeldScan::*field) {
    std::vector<double> sb(bl.size(), 0), sa(bl.size(), 0);
    std::vector<int> cb(bl.size(), 0), ca(bl.size(), 0);
    for (const HeldScan& h : held_before)
      if (const int k = en.blockAt(h.t); k >= 0 && std::isfinite(h.*field)) sb[k] += h.*field, ++cb[k];
    for (const HeldScan& h : held_after)
      if (const int k = en.blockAt(h.t); k >= 0 && std::isfinite(h.*field)) sa[k] += h.*field, ++ca[k];
    std::vector<double> d;
    int improved = 0;
    for (std::size_t k = 0; k < bl.size(); ++k) {
      if (cb[k] == 0 || ca[k] == 0) continue;
      d.push_back(sa[k] / ca[k] - sb[k] / cb[k]);
      improved += d.back() < 0 ? 1 : 0;
    }
    double dm = 0, dv = 0;
    for (double x : d) dm += x / double(d.size());
    for (double x : d) dv += (x - dm) * (x - dm) / std::max(1.0, double(d.size()) - 1);
    json r = {{"blocks", d.size()},
              {"blocks_better", improved},
              {"change_mean", d.empty() ? json(nullptr) : json(dm)},
              {"change_z", d.size() > 1 && dv > 0 ? json(dm / std::sqrt(dv / double(d.size()))) : json(nullptr)}};
    return r;
  };
  json blocks = json::array();
  for (const auto& h : bl) blocks.push_back({h.first, h.second});
  res.json = {{"with", names},
             {"folds", folds},
             {"folds_failed", failed},
             {"fits", fits},
             {"blocks", blocks},
             {"gap_s", opt.gap_s},
             {"reanchor_s", opt.reanchor_s},
             {"before", metrics(before)},
             {"after", metrics(after)},
             {"paired", {{"nis", paired(&HeldScan::nis)}, {"nll", paired(&HeldScan::nll)},
                         {"pose_err_m", paired(&HeldScan::pose_err)}}}};
  res.json["region_beams_left_out"] = leave_out != nullptr ? json(n_left_out) : json(nullptr);
  if (folds == 0) {
    char note[160];
    std::snprintf(note, sizeof note, "no held-out block: the drive is shorter than warm-up + gap + one block (%.1f s)",
                  opt.warmup_s + opt.gap_s + opt.block_s);
    res.json["note"] = note;
  }
  return res;
}

bool writeHeldoutCsv(const std::string& dir, const HeldoutResult& r, std::string* error) {
  for (const auto& [name, rows] : {std::pair{"heldout_before.csv", &r.before}, {"heldout_after.csv", &r.after}}) {
    std::ofstream f(std::filesystem::path(dir) / name);
    f << "t,nis,nll,pose_err_m\n";
    char buf[96];
    for (const HeldScan& h : *rows) {
      std::snprintf(buf, sizeof buf, "%.3f,%.4f,%.4f,%.5f\n", h.t, h.nis, h.nll, h.pose_err);
      f << buf;
    }
    if (!f) {
      *error = "cannot write '" + (std::filesystem::path(dir) / name).string() + "'";
      return false;
    }
  }
  return true;
}

#define ODOERR_HELDOUT(EN) \
  template HeldoutResult compareModels<EN>(const EN&, const std::vector<int>&, const EN&, const std::vector<int>&, \
                                           const std::vector<std::string>&, const DiagnoseOptions&, \
                                           const std::vector<std::uint8_t>*);
using SyncEngine = Engine<SyncDrive>;
using DiffEngine = Engine<DiffDrive>;
using SyncFeatured = Engine<SyncDrive, Featured>;
using DiffFeatured = Engine<DiffDrive, Featured>;
ODOERR_HELDOUT(SyncEngine)
ODOERR_HELDOUT(DiffEngine)
ODOERR_HELDOUT(SyncFeatured)
ODOERR_HELDOUT(DiffFeatured)
#undef ODOERR_HELDOUT

}  // namespace odoerr::sim::diag
