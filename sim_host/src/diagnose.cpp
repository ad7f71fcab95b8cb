// odoerr diagnose: the orchestration. The parts live in sim_host/src/diagnose/, one
// responsibility each: engine (the filter runs over a log), ranking (the catalogue's
// effects scored and tested), heldout (the cross-validated comparison), excitation (what
// the drive determines) and stats.cpp (the consistency tests, bins and CUSUM).
#include "odoerr/sim/diagnose.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "diagnose/discovery.hpp"
#include "diagnose/engine.hpp"
#include "diagnose/excitation.hpp"
#include "diagnose/heldout.hpp"
#include "diagnose/map_misfit.hpp"
#include "diagnose/model_search.hpp"
#include "diagnose/physical.hpp"
#include "diagnose/power.hpp"
#include "diagnose/ranking.hpp"
#include "odoerr/sim/odolog_json.hpp"

namespace odoerr::sim {

namespace {

using json = nlohmann::ordered_json;
using namespace diag;

constexpr double kMinExplained = 0.2;  // a named effect must explain this share of the misfit discovery finds

template <template <typename> class DriveT>
bool diagnoseDrive(const Odolog& log, const DiagnoseOptions& opt, json* out, std::string* error) {
  using En = Engine<DriveT>;
  using RunSpec = typename En::RunSpec;
  using RunOut = typename En::RunOut;
  using Drive = typename En::Drive;
  constexpr int kD = En::kD;
  En en(log, opt);
  if (!en.prepare(error)) return false;
  const auto& fx = en.effects();
  const int ne = static_cast<int>(fx.size());
  WithSpec with;
  if (!parseWith(opt.with, fx, En::kSync, &with, error)) return false;
  if (with.automatic && (!with.catalogue.empty() || !with.features.empty())) {
    *error = "--with auto chooses the effects itself: give it alone";
    return false;
  }
  for (const Term& t : with.features)
    if (t.kind == Term::Kind::kMotion && effects::isStepFeature(t.mf) && !std::isfinite(opt.change_at_s)) {
      *error = "--with: feature:" + t.name() + "@" + t.target() + " is a step at a time: give it with --change-at T";
      return false;
    }
  const std::vector<int>& with_idx = with.catalogue;
  const bool held_out = !with.catalogue.empty() || !with.features.empty();

  // 1. The model as the user has it: drive parameters and K estimated (the OF free).
  //    And the joint run: every augmentable candidate free, the OF free. Its K cannot have
  //    been inflated to absorb a systematic effect (the effect is in its model); every
  //    scoring run holds K there, so the OF is not free to hide an effect by inflating noise.
  //    Its covariance also gives the information structure (confusable pairs).
  RunOut base_free, joint;
  {
    std::vector<std::function<void()>> first;
    first.push_back([&] { base_free = en.run(en.nominalSpec(en.initialK(), true)); });
    first.push_back([&] {
      RunSpec s = en.nominalSpec(en.initialK(), true);
      for (int e = 0; e < ne; ++e)
        if (fx[e].kind != EffectKind::kNoise) en.freeEffect(&s, e);
      joint = en.run(s);
    });
    runParallel(first, opt.threads);
  }
  const auto k_hat = joint.k;
  // 2. The reference for scoring, K held (the OF may not hide an effect by inflating noise).
  //    It also fixes the set of beams every run is scored on.
  RunSpec base_spec = en.nominalSpec(k_hat, false);
  base_spec.record = true;
  base_spec.residuals = true;
  std::vector<std::uint8_t> scored(en.scoredSize(), 0);
  base_spec.make_scored = &scored;
  const RunOut base = en.run(base_spec);
  long n_innov = std::max(1L, base.n_innov);
  double l0 = base.loglik;
  // 3. Where the map is wrong: the residuals at the beams' hit points. Beams that end in a
  //    region the map gets wrong say nothing about the odometry: by default they leave the
  //    scored set (the reference is scored again on what is left), and the ranking with
  //    them is reported too.
  const MapMisfit map_misfit = mapMisfit(en, base, opt.map_cell_m);
  const std::vector<std::uint8_t> scored_all = scored;
  RunSpec ref0 = en.nominalSpec(k_hat, false);
  const bool exclude = opt.map_exclude && !map_misfit.regions.empty();
  if (exclude) {
    for (std::size_t k = 0; k < scored.size() && k < map_misfit.in_region.size(); ++k)
      if (map_misfit.in_region[k]) scored[k] = 0;
    ref0.scored = &scored;
    const RunOut ref_run = en.run(ref0);
    n_innov = std::max(1L, ref_run.n_innov);
    l0 = ref_run.loglik;
  }
  // 4. Every candidate scored against the reference, ranked and tested.
  ref0.scored = &scored;
  Ranking<DriveT> rank(en, opt.threads);
  rank.run(ref0, l0, n_innov);
  // A named effect must be physically possible (docs/diagnostics.md, "Physical bounds").
  for (int e : rank.named()) {
    const Candidate& c = rank.candidates()[static_cast<std::size_t>(e)];
    for (int i = 0; i < fx[e].n && i < c.est.size(); ++i) {
      const std::string why = physicalViolation(fx[e].name, i, c.est[i], c.sig[i]);
      if (!why.empty()) {
        rank.unname(e, why);
        break;
      }
    }
  }
  json ranking_other = nullptr;  // the ranking with the region beams, when they were left out
  if (exclude) {
    RunSpec ref_all = ref0;
    ref_all.scored = &scored_all;
    Ranking<DriveT> rank_all(en, opt.threads);
    rank_all.run(ref_all, base.loglik, std::max(1L, base.n_innov));
    ranking_other = json::array();
    for (const RankRow& r : rank_all.rows())
      ranking_other.push_back({{"effect", fx[r.e].name}, {"significant", r.significant}, {"p_value", r.p}});
  }

  // 5. Discovery: the residuals of the model as it is, regressed on the feature library;
  //    then with each named effect in the model, and with all of them: how much of the
  //    misfit each explains (an effect that explains little of it is not named: a wrong
  //    kind absorbs a part of a misfit, never most of it), and what is left.
  Discovery<En> disc(en, opt);
  Scales scales;
  const Residuals res_base = disc.analyse(base, &scales);
  const double misfit = structuredMisfit(res_base.motion_sel) + structuredMisfit(res_base.beam_sel);
  // A run of the model with `effects` held at their estimates, recording its residuals.
  auto residualRun = [&](const std::vector<int>& effects) {
    RunSpec s = rank.heldAt(effects);
    s.scored = nullptr;
    s.residuals = true;
    return en.run(s);
  };
  const std::vector<int> named0 = rank.named();
  std::vector<json> explains(named0.size());
  std::vector<Residuals> res_named(named0.size());
  {
    std::vector<RunOut> runs(named0.size());
    std::vector<std::function<void()>> tasks;
    for (std::size_t i = 0; i < named0.size(); ++i) tasks.push_back([&, i] { runs[i] = residualRun({named0[i]}); });
    runParallel(tasks, opt.threads);
    for (std::size_t i = 0; i < named0.size(); ++i) {
      res_named[i] = disc.analyse(runs[i], &scales);
      explains[i] = explainedBy(res_base, res_named[i]);
      const json& tot = explains[i]["total"];
      if (misfit > 0 && tot.is_number() && tot.template get<double>() < kMinExplained) {
        char why[200];
        std::snprintf(why, sizeof why,
                      "it explains %.0f %% of the misfit the residuals show (motion and beams together); "
                      "an effect of the right form explains most of it",
                      100 * tot.template get<double>());
        rank.unname(named0[i], why);
      }
    }
    // The kind: an effect whose evidence lies only in the other kind's residuals is not
    // named when an effect of that kind explains them as well (a laser offset mimics a
    // slip in turns; a slip can absorb part of a beam-angle error).
    auto share = [](const json& x, const char* k) { return x[k].is_number() ? x[k].template get<double>() : -1.0; };
    for (std::size_t i = 0; i < named0.size(); ++i) {
      const EffectKind ki = fx[named0[i]].kind;
      if (ki == EffectKind::kNoise) continue;
      const char* own = ki == EffectKind::kMotion ? "motion" : "beam";
      const char* other = ki == EffectKind::kMotion ? "beam" : "motion";
      if (share(explains[i], own) >= kMinExplained || share(explains[i], other) < kMinExplained) continue;
      for (std::size_t k = 0; k < named0.size(); ++k) {
        const EffectKind kk = fx[named0[k]].kind;
        if (k == i || kk == ki || kk == EffectKind::kNoise) continue;
        if (share(explains[k], other) >= share(explains[i], other)) {
          const std::string why = std::string("its evidence is in the ") + other + " residuals, which " +
                                  fx[named0[k]].name + ", an effect of that kind, explains as well";
          rank.unname(named0[i], why);
          break;
        }
      }
    }
  }
  // A named effect on a drive whose residuals show no structure (discovery finds no misfit)
  // has only the likelihood for it: the held-out data must not contradict it.
  json confirmations = json::array();
  if (!(misfit > 0))
    for (int e : rank.named()) {
      json c = confirmHeldout(en, e, opt, exclude ? &map_misfit.in_region : nullptr);
      if (!c["confirmed"].template get<bool>())
        rank.unname(e, "discovery sees no structure in the residuals, and the held-out data contradict it (paired z " +
                           fmt("%.1f", c["z"].template get<double>()) + " at best, " +
                           fmt("%+.1f", c["worst_z"].template get<double>()) + " at worst)");
      confirmations.push_back(std::move(c));
    }
  // The rival test: a named effect against the features of the other kind that discovery
  // found in the baseline, on held-out data; the form of the right kind wins over a mimic.
  json rivals = json::array();
  for (int e : rank.named()) {
    json r = rivalTest(en, e, res_base, opt, exclude ? &map_misfit.in_region : nullptr);
    if (r.is_null()) continue;
    if (r["won"].template get<bool>())
      rank.unname(e, "the " + std::string(fx[e].kind == EffectKind::kMotion ? "beam" : "motion") +
                         " features discovery found (" + r["rival"].template get<std::string>() +
                         ") predict the held-out " + (r["decided_by"] == "nll" ? "beams" : "poses") + " better (paired z " +
                         fmt("%.1f", r["z"].template get<double>()) +
                         "): " + fx[e].name + " mimics a form of the other kind");
    rivals.push_back(std::move(r));
  }
  const std::vector<int> named = rank.named();
  Residuals res_final;
  if (named.size() == 1) {  // that effect's own run: already analysed
    res_final = res_named[static_cast<std::size_t>(std::find(named0.begin(), named0.end(), named[0]) - named0.begin())];
  } else if (!named.empty()) {
    res_final = disc.analyse(residualRun(named), &scales);
  }
  const json unexplained = unexplainedJson(res_base, named.empty() ? res_base : res_final, !named.empty());
  // The non-parametric step: on which state variables the motion misfit of the model as it
  // was depends; each finding lists the library's forms in its variable that discovery
  // selected (none: a form the library lacks). Its findings are leads (printed, proposed to
  // --with auto), not the verdict; a variable that follows the misfit is not one
  // (docs/diagnostics.md, "Dependence").
  json dependence = {{"baseline", dependenceJson(res_base.state)}};
  if (json& found = dependence["baseline"]["found"]; found.is_array())
    for (json& f : found) {
      json sel = json::array();
      const std::vector<std::string> forms = f["library_forms"];
      const std::string component = f["component"];
      for (int j : res_base.motion_sel.terms) {
        const Term& tm = res_base.motion_terms[static_cast<std::size_t>(j)];
        if (std::find(forms.begin(), forms.end(), tm.name()) != forms.end() && targetMoves(tm.target(), component))
          sel.push_back(tm.name() + "@" + tm.target());
      }
      f["selected_forms"] = sel;
    }
  const json change_points = disc.changePoints(res_base, named.empty() ? nullptr : &res_final);
  json ranking = rank.toJson(joint);
  for (json& row : ranking)
    for (std::size_t i = 0; i < named0.size(); ++i)
      if (row["effect"] == fx[named0[i]].name) row["explains"] = explains[i];
  const json excitation = excitationReport(en, base_free, rank.candidates(), log.has_laser);
  json power = detectionPower(fx, rank.candidates(), n_innov, log.has_laser);
  power["features"] = featurePower(res_base);

  // Statistics of the baseline (K held) and the verdict.
  const bool with_fixes = !log.poses.empty();
  const DriveStats st = computeStats(base.scans, base.beams, base.obs.empty() ? base_free.obs : base.obs,
                                     log.param("wheel_radius_m", 0.05), base.fixes, log.has_laser, with_fixes);
  json tests = st.tests;
  // Parameter NEES against the logged truth (meta truth_param NAME VALUE).
  {
    std::vector<int> idx;
    std::vector<double> tv;
    for (const auto& [k, v] : log.meta) {
      if (k != "truth_param") continue;
      char name[64];
      double val;
      if (std::sscanf(v.c_str(), "%63s %lf", name, &val) != 2) continue;
      for (int i = 0; i < Drive::kParams; ++i)
        if (std::string(name) == Drive::kParamNames[i]) {
          idx.push_back(kD + i);
          tv.push_back(val);
        }
    }
    if (!idx.empty()) {
      Eigen::VectorXd e(idx.size());
      Eigen::MatrixXd p(idx.size(), idx.size());
      for (std::size_t a = 0; a < idx.size(); ++a) {
        e[a] = base_free.x[idx[a]] - tv[a];
        for (std::size_t b = 0; b < idx.size(); ++b) p(a, b) = base_free.p(idx[a], idx[b]);
      }
      tests["nees_params"] = e.dot(p.ldlt().solve(e));
      tests["nees_params_dof"] = idx.size();
    } else {
      tests["nees_params"] = nullptr;
    }
  }
  const bool consistent = !rank.anySignificant() && st.consistent && !unexplained["significant"].template get<bool>() &&
                          change_points.empty() && map_misfit.regions.empty();

  // 6. Held-out comparison (--with): catalogue effects on the catalogue's model; with
  //    feature terms, on the model with the feature effects, their slots configured.
  HeldoutResult held;
  json heldout = nullptr;
  if (held_out && with.features.empty()) {
    held = compareHeldout(en, {}, with_idx, with.names, opt, exclude ? &map_misfit.in_region : nullptr);
    heldout = held.json;
  } else if (held_out) {
    using EnF = Engine<DriveT, Featured>;
    EnF before(log, opt), after(log, opt,
                                 slotsFor(with.features, res_base,
                                          std::isfinite(opt.change_at_s) ? opt.change_at_s
                                                                         : std::numeric_limits<double>::infinity()));
    if (!before.prepare(error) || !after.prepare(error)) return false;
    std::vector<int> added = with_idx;
    if (!after.slots().motion.empty()) added.push_back(ne);
    if (!after.slots().beam.empty()) added.push_back(ne + 1);
    held = compareHeldout(before, {}, after, added, with.names, opt, exclude ? &map_misfit.in_region : nullptr);
    heldout = held.json;
  }
  // 7. --with auto: forward selection over the named effects and the discovered features.
  json automatic = nullptr;
  if (with.automatic) {
    std::vector<std::string> final_with;
    // the change point discovery found (the first), whose step is a candidate
    double change_t = std::numeric_limits<double>::quiet_NaN();
    if (!change_points.empty() && change_points[0]["t"].is_number()) change_t = change_points[0]["t"].template get<double>();
    automatic = autoSearch(en, rank, res_base, scales, opt, &final_with, exclude ? &map_misfit.in_region : nullptr,
                           change_t, dependence["baseline"]["found"]);
  }
  if (!opt.suggest_dir.empty()) {
    const Residuals& r = named.empty() || !unexplained["significant"].template get<bool>() ? res_base : res_final;
    std::vector<Term> terms;
    std::vector<double> coef, sigma;
    for (const auto& [sel, tl] : {std::pair{&r.motion_sel, &r.motion_terms}, {&r.beam_sel, &r.beam_terms}})
      for (std::size_t k = 0; k < sel->terms.size() && k < sel->coef.size(); ++k) {
        terms.push_back((*tl)[static_cast<std::size_t>(sel->terms[k])]);
        coef.push_back(sel->coef[k]);
        sigma.push_back(sel->sigma[k]);
      }
    if (!writeSuggestion(opt.suggest_dir, terms, coef, sigma, error)) return false;
  }

  json walls = json::array();
  for (const auto& w : log.walls) walls.push_back({w.x1, w.y1, w.x2, w.y2});
  json& j = *out;
  j = json::object();
  j["log"] = log.path;
  j["drive"] = log.drive;
  j["verdict"] = !st.has_data ? "insufficient data" : consistent ? "consistent" : "inconsistent";
  if (!st.has_data) j["verdict_missing"] = st.missing;
  // "Consistent" says what the drive could not have missed (power.hpp).
  if (st.has_data && consistent) j["verdict_detail"] = "consistent: " + nothingLargerThan(power);
  j["encoder_rejections"] = rejectionsJson(log);
  {
    // What the verdict rests on that the user must know: increments the reader rejected.
    json caveats = json::array();
    if (!log.enc_rejected.empty()) caveats.push_back(rejectionSummary(log));
    j["verdict_caveats"] = caveats;
  }
  j["tests"] = tests;
  j["ranking"] = ranking;
  j["heldout"] = heldout;
  j["unexplained"] = unexplained;
  j["rivals"] = rivals;
  j["heldout_confirmations"] = confirmations;
  j["dependence"] = dependence;
  j["change_points"] = change_points;
  j["map_misfit"] = mapMisfitJson(map_misfit, opt.out_dir.empty() ? "" : "map_grid.csv");
  j["map_misfit"]["region_beams"] =
      exclude ? "left out of the ranking and the held-out comparison" : (opt.map_exclude ? "none" : "kept (--map-beams keep)");
  j["map_misfit"]["ranking_with_region_beams"] = ranking_other;
  if (with.automatic) j["auto"] = automatic;
  j["excitation"] = excitation;
  j["detection_power"] = power;
  j["bins"] = st.bins;
  j["cusum"] = st.cusum;
  j["baseline"] = {{"innovations", n_innov},
                   {"loglik", l0},
                   {"k_estimate", std::vector<double>(base_free.k.data(), base_free.k.data() + base_free.k.size())},
                   {"k_held", std::vector<double>(k_hat.data(), k_hat.data() + k_hat.size())},
                   {"parameters", [&] {
                      json p = json::object();
                      for (int i = 0; i < Drive::kParams; ++i)
                        p[Drive::kParamNames[i]] = {{"estimate", base_free.x[kD + i]},
                                                    {"sigma", std::sqrt(base_free.p(kD + i, kD + i))}};
                      return p;
                    }()}};
  j["map"] = {{"walls", walls}};

  if (!opt.out_dir.empty()) {
    if (!writeDiagnoseCsv(opt.out_dir, base.scans, base.beams, base.traj, error)) return false;
    if (held_out && !writeHeldoutCsv(opt.out_dir, held, error)) return false;
    // the residuals of what is left, or of the baseline when the named effects leave nothing
    const bool left = !named.empty() && unexplained["significant"].template get<bool>();
    if (!writeDiscoveryCsv(opt.out_dir, left ? res_final : res_base, error)) return false;
    if (!writeMapCsv(opt.out_dir, map_misfit, error)) return false;
  }
  return true;
}

}  // namespace

std::vector<std::string> diagnoseEffectNames() {
  std::vector<std::string> v;
  std::apply([&](auto... e) { (v.push_back(decltype(e)::kName), ...); }, Catalogue{});
  return v;
}

bool diagnoseOdolog(const Odolog& log, const DiagnoseOptions& opt, json* out, std::string* error) {
  return log.drive == "sync" ? diagnoseDrive<SyncDrive>(log, opt, out, error)
                             : diagnoseDrive<DiffDrive>(log, opt, out, error);
}

}  // namespace odoerr::sim
