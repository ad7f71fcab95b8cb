#include "model_search.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "dependence.hpp"
#include "heldout.hpp"

namespace odoerr::sim::diag {

namespace {

using json = nlohmann::ordered_json;
using effects::BeamFeature;
using effects::MotionFeature;
using effects::MotionTarget;

constexpr int kMaxSteps = 3;        // --with auto adds at most this many effects
constexpr double kAcceptZ = -2.0;   // a step is kept when the held-out error falls by this paired z
constexpr double kWorseZ = 2.0;     // a named effect is not confirmed when a held-out error rises this much

bool sameTerm(const Term& a, const Term& b) {
  return a.kind == b.kind && a.mf == b.mf && a.mt == b.mt && a.bf == b.bf && a.wheel == b.wheel;
}

/// The score of a held-out comparison: the deciding metric, its paired z, and whether it
/// falls enough for a step (`ok`; false when the metric has no z).
struct Score {
  const char* by = "nll";
  double z = 0;
  bool ok = false;
};

/// The highest paired z (the worst rise) over the NLL and, when the log has truth, the pose
/// error; 0 without either.
double worstZ(const json& held) {
  const json& p = held["paired"];
  double w = -std::numeric_limits<double>::infinity();
  for (const char* k : {"nll", "pose_err_m"})
    if (p.contains(k) && p[k]["change_z"].is_number()) w = std::max(w, p[k]["change_z"].get<double>());
  return std::isfinite(w) ? w : 0.0;
}

/// The deciding score of a held-out comparison (a --with auto step, a rival test, a named
/// effect's confirmation): the held-out pose error's paired z where the log has truth (the
/// error the user wants lowered), the NLL's otherwise, and always for what adds only noise
/// effects (`noise`: they move no pose, they widen its uncertainty). The other metrics are
/// reported beside it, not voted: with truth, a candidate that lowers the pose error may
/// raise the beams' NLL (a filter more confident than it should be), and one that lowers only
/// the NLL has not made the odometry better.
Score decidingScore(const json& held, bool noise = false) {
  Score s;
  const json& p = held["paired"];
  const bool truth = p.contains("pose_err_m") && p["pose_err_m"]["change_z"].is_number();
  s.by = truth && !noise ? "pose_err_m" : "nll";
  if (!p.contains(s.by) || !p[s.by]["change_z"].is_number()) return s;
  s.z = p[s.by]["change_z"].get<double>();
  s.ok = s.z <= kAcceptZ;
  return s;
}

/// The selection of a residual design over the terms a feature effect carries: the
/// design's own when it holds no host-only term (a reversal count, the time), else the
/// forward selection again with those columns zeroed.
Selection carriedSelection(const Design& d, const Selection& sel, const std::vector<Term>& terms) {
  if (std::none_of(sel.terms.begin(), sel.terms.end(),
                   [&](int j) { return withToken(terms[static_cast<std::size_t>(j)]).empty(); }))
    return sel;
  Design c = d;
  for (std::size_t j = static_cast<std::size_t>(c.n_nuisance); j < terms.size(); ++j)
    if (withToken(terms[j]).empty()) c.x.col(static_cast<Eigen::Index>(j)).setZero();
  return forwardSelect(c, SelectOptions{});
}

}  // namespace

bool parseWith(const std::vector<std::string>& tokens, const std::vector<EffectInfo>& catalogue, bool sync,
               WithSpec* out, std::string* error) {
  bool feature_mode = false;
  for (const std::string& tok : tokens) {
    if (tok == "auto") {
      out->automatic = true;
      continue;
    }
    int found = -1;
    for (std::size_t e = 0; e < catalogue.size(); ++e)
      if (catalogue[e].name == tok) found = static_cast<int>(e);
    if (found >= 0) {
      out->catalogue.push_back(found);
      out->names.push_back(tok);
      feature_mode = false;
      continue;
    }
    std::string spec = tok;
    if (spec.rfind("feature:", 0) == 0) {
      spec = spec.substr(8);
      feature_mode = true;
    } else if (!feature_mode) {
      std::string names;
      for (const auto& f : catalogue) names += (names.empty() ? "" : ", ") + f.name;
      *error = "--with: unknown effect '" + tok + "' (the catalogue: " + names +
               "; or auto; or feature:NAME@TARGET, feature:BEAM_FEATURE)";
      return false;
    }
    const std::size_t at = spec.find('@');
    const std::string name = spec.substr(0, at), target = at == std::string::npos ? "" : spec.substr(at + 1);
    Term t{Term::Kind::kBeam};
    if (effects::parseBeamFeature(name.c_str(), &t.bf) && (target.empty() || target == "range")) {
      t.kind = Term::Kind::kBeam;
    } else if (effects::parseMotionFeature(name.c_str(), &t.mf) && t.mf != MotionFeature::kNone) {
      t.kind = Term::Kind::kMotion;
      if (!effects::parseMotionTarget(target.c_str(), &t.mt)) {
        *error = "--with: feature '" + tok + "' needs a target: NAME@TARGET, TARGET one of along, cross, heading, "
                 "world_x, world_y, wheel_R, wheel_L";
        return false;
      }
      if (sync && (t.mt == MotionTarget::kWheelR || t.mt == MotionTarget::kWheelL || t.mf == MotionFeature::kDsR ||
                   t.mf == MotionFeature::kDsL || t.mf == MotionFeature::kDsRSpeed || t.mf == MotionFeature::kDsLSpeed)) {
        *error = "--with: feature '" + tok + "' is a wheel's: a synchronous drive has none";
        return false;
      }
    } else {
      *error = "--with: unknown feature '" + tok + "' (motion features: ds, abs_ds, dth, abs_dth, ds_R, ds_L, "
               "ds_R_speed, ds_L_speed, v_w, v2, w2, cos_heading_ds, sin_heading_ds, x_ds, y_ds, s_ds, dt; beam "
               "features: one, range, abs_inc, inc2, inv_cos_inc, alpha, alpha2, angle_sens, alpha_angle_sens, v, w, "
               "w_angle_sens)";
      return false;
    }
    if (std::any_of(out->features.begin(), out->features.end(), [&](const Term& q) { return sameTerm(q, t); })) continue;
    out->features.push_back(t);
    out->names.push_back(withToken(t));
  }
  std::size_t nm = 0, nb = 0;
  for (const Term& t : out->features) (t.kind == Term::Kind::kBeam ? nb : nm)++;
  if (nm > FeatureSlots::kMax || nb > FeatureSlots::kMax) {
    *error = "--with: at most 4 motion and 4 beam features (the feature effects' slots)";
    return false;
  }
  return true;
}

FeatureSlots slotsFor(const std::vector<Term>& terms, const Residuals& base, double t_change) {
  FeatureSlots s;
  s.t_change = t_change;
  for (const Term& t : terms) {
    if (t.kind == Term::Kind::kMotion && effects::isStepFeature(t.mf)) {
      s.motion.push_back({t.mf, t.mt, 0.1, 0.005});
      continue;
    }
    const bool beam = t.kind == Term::Kind::kBeam;
    const std::vector<Term>& cols = beam ? base.beam_terms : base.motion_terms;
    const Design& d = beam ? base.beam : base.motion;
    double prior = 0, ref = 0;
    for (std::size_t j = 0; j < cols.size(); ++j) {
      if (!sameTerm(cols[j], t) || d.x.rows() == 0) continue;
      const Selection f = fitTerms(d, {static_cast<int>(j)});
      if (!f.coef.empty() && std::isfinite(f.coef[0]) && std::isfinite(f.sigma[0])) {
        prior = std::max(3 * std::abs(f.coef[0]), 20 * f.sigma[0]);
        ref = std::max(std::abs(f.coef[0]), 3 * f.sigma[0]);
      }
    }
    if (!(prior > 0)) {  // not in the design (a sync drive's wheel term): a wide prior
      prior = 1.0;
      ref = 0.01;
    }
    if (beam) {
      s.beam.push_back({t.bf, prior, ref});
    } else {
      s.motion.push_back({t.mf, t.mt, prior, ref});
    }
  }
  return s;
}

template <template <typename> class DriveT>
json autoSearch(const Engine<DriveT>& en, const Ranking<DriveT>& rank, const Residuals& base, const Scales& scales,
                const DiagnoseOptions& opt, std::vector<std::string>* final_with,
                const std::vector<std::uint8_t>* leave_out, double change_t, const json& dependence) {
  using EnF = Engine<DriveT, Featured>;
  const double tc = std::isfinite(change_t) ? change_t : std::numeric_limits<double>::infinity();
  using RunSpecF = typename EnF::RunSpec;
  const auto& fx = en.effects();
  const int ne = static_cast<int>(fx.size());  // the feature effects follow the catalogue
  const Odolog& log = en.log();
  std::vector<int> cur_cat;
  std::vector<Term> cur_terms;
  std::vector<std::string> cur_names;
  Residuals res = base;
  json steps = json::array(), tried = json::array();
  auto indices = [&](const std::vector<int>& cat, const FeatureSlots& sl) {
    std::vector<int> v = cat;
    if (!sl.motion.empty()) v.push_back(ne);
    if (!sl.beam.empty()) v.push_back(ne + 1);
    return v;
  };
  for (int step = 0; step < kMaxSteps; ++step) {
    struct Cand {
      std::string name;
      std::vector<int> cat;
      std::vector<Term> terms;
    };
    std::vector<Cand> cands;
    // A term joins a feature candidate once; the candidate fits when its terms fit the slots.
    auto addTerm = [](Cand* c, const Term& t) {
      if (std::any_of(c->terms.begin(), c->terms.end(), [&](const Term& q) { return sameTerm(q, t); })) return;
      c->terms.push_back(t);
      c->name += (c->name.empty() ? "" : ",") + withToken(t);
    };
    auto fits = [](const Cand& c) {
      std::size_t nm = 0, nb = 0;
      for (const Term& t : c.terms) (t.kind == Term::Kind::kBeam ? nb : nm)++;
      return !c.name.empty() && nm <= FeatureSlots::kMax && nb <= FeatureSlots::kMax;
    };
    for (int e : rank.named()) {  // the best named catalogue effect not in the model yet
      if (std::find(cur_cat.begin(), cur_cat.end(), e) != cur_cat.end()) continue;
      Cand c{fx[e].name, cur_cat, cur_terms};
      c.cat.push_back(e);
      cands.push_back(c);
      break;
    }
    {  // the features the current model's residuals still depend on, together
      Cand c{"", cur_cat, cur_terms};
      auto take = [&](const Selection& sel, const std::vector<Term>& terms) {
        for (int j : sel.terms) {
          const Term& t = terms[static_cast<std::size_t>(j)];
          if (!withToken(t).empty()) addTerm(&c, t);  // a host-only term: no feature effect carries it
        }
      };
      take(carriedSelection(res.motion, res.motion_sel, res.motion_terms), res.motion_terms);
      take(carriedSelection(res.beam, res.beam_sel, res.beam_terms), res.beam_terms);
      if (fits(c)) cands.push_back(c);
    }
    // The forms the non-parametric step proposes in the variables the misfit depends on (its
    // two strongest findings): their feature terms together, and each catalogue effect.
    if (dependence.is_array())
      for (std::size_t k = 0; k < dependence.size() && k < 2; ++k) {
        const ProposedForms pf = proposedForms(dependence[k]["variable"].get<std::string>(),
                                               dependence[k]["component"].get<std::string>());
        Cand c{"", cur_cat, cur_terms};
        for (const std::string& tok : pf.features) {
          const std::size_t at = tok.find('@');
          Term t{Term::Kind::kMotion};
          if (!effects::parseMotionFeature(tok.substr(0, at).c_str(), &t.mf) ||
              !effects::parseMotionTarget(tok.substr(at + 1).c_str(), &t.mt))
            continue;
          if (!(Engine<DriveT>::kSync && (t.mt == MotionTarget::kWheelR || t.mt == MotionTarget::kWheelL)))
            addTerm(&c, t);
        }
        auto known = [&](const std::string& n) {
          return std::any_of(cands.begin(), cands.end(), [&](const Cand& q) { return q.name == n; });
        };
        if (fits(c) && !known(c.name)) cands.push_back(c);
        for (const std::string& name : pf.catalogue)
          for (int e = 0; e < static_cast<int>(fx.size()); ++e)
            if (fx[e].name == name && std::find(cur_cat.begin(), cur_cat.end(), e) == cur_cat.end() && !known(name)) {
              Cand q{name, cur_cat, cur_terms};
              q.cat.push_back(e);
              cands.push_back(q);
            }
      }
    if (std::isfinite(tc)) {  // the drive parameters' step at the change point
      Cand c{"", cur_cat, cur_terms};
      std::vector<Term> jump;
      if constexpr (Engine<DriveT>::kSync) {
        jump = {{Term::Kind::kMotion, MotionFeature::kDsAfter, MotionTarget::kAlong},
                {Term::Kind::kMotion, MotionFeature::kDsAfter, MotionTarget::kHeading}};
      } else {
        jump = {{Term::Kind::kMotion, MotionFeature::kDsRAfter, MotionTarget::kWheelR},
                {Term::Kind::kMotion, MotionFeature::kDsLAfter, MotionTarget::kWheelL}};
      }
      for (const Term& t : jump) addTerm(&c, t);
      if (fits(c)) {
        c.name += " (step at t = " + fmt("%.1f", tc) + " s)";
        cands.push_back(c);
      }
    }
    if (cands.empty()) break;
    const FeatureSlots cur_slots = slotsFor(cur_terms, base, tc);
    EnF before(log, opt, cur_slots);
    std::string err;
    if (!before.prepare(&err)) break;
    int best = -1;
    Score best_s;
    json best_held;
    for (std::size_t c = 0; c < cands.size(); ++c) {
      const FeatureSlots sl = slotsFor(cands[c].terms, base, tc);
      EnF after(log, opt, sl);
      if (!after.prepare(&err)) continue;
      const std::vector<int> b_idx = indices(cur_cat, cur_slots);
      std::vector<int> a_idx = indices(cands[c].cat, sl), added;
      for (int i : a_idx)
        if (std::find(b_idx.begin(), b_idx.end(), i) == b_idx.end()) added.push_back(i);
      const HeldoutResult h = compareHeldout(before, b_idx, after, added, {cands[c].name}, opt, leave_out);
      const bool noise = !added.empty() && std::all_of(added.begin(), added.end(), [&](int i) {
        return after.effects()[static_cast<std::size_t>(i)].kind == EffectKind::kNoise;
      });
      const Score s = decidingScore(h.json, noise);
      tried.push_back({{"step", step}, {"added", cands[c].name}, {"paired", h.json["paired"]}, {"kept", false}});
      if (s.ok && (best < 0 || s.z < best_s.z)) {
        best = static_cast<int>(c);
        best_s = s;
        best_held = h.json;
      }
    }
    if (best < 0) break;
    for (json& t : tried)
      if (t["step"] == step && t["added"] == cands[static_cast<std::size_t>(best)].name) t["kept"] = true;
    cur_cat = cands[static_cast<std::size_t>(best)].cat;
    cur_terms = cands[static_cast<std::size_t>(best)].terms;
    cur_names.push_back(cands[static_cast<std::size_t>(best)].name);
    // The model as it now is: fitted on the whole drive, then its residuals.
    const FeatureSlots sl = slotsFor(cur_terms, base, tc);
    EnF now(log, opt, sl);
    if (!now.prepare(&err)) break;
    RunSpecF fit = now.nominalSpec(now.initialK(), true);
    for (int e : indices(cur_cat, sl)) {
      if (now.effects()[e].kind == EffectKind::kNoise) {
        fit.eff_val[now.effects()[e].offset - EnF::kE] = rank.candidates()[e].q_best;
      } else {
        now.freeEffect(&fit, e);
      }
    }
    const auto fitted = now.run(fit);
    RunSpecF held = now.nominalSpec(fitted.k, false);
    held.hold_drive = true;
    held.drive_val = fitted.x.template segment<EnF::Drive::kParams>(EnF::kD);
    for (int i = 0; i < EnF::M::kEffectParams; ++i) held.eff_val[i] = fitted.x[EnF::kE + i];
    for (int e : indices(cur_cat, sl))
      if (now.effects()[e].kind == EffectKind::kNoise) held.eff_val[now.effects()[e].offset - EnF::kE] = fit.eff_val[now.effects()[e].offset - EnF::kE];
    held.residuals = true;
    Scales sc = scales;
    const Discovery<EnF> disc(now, opt);
    res = disc.analyse(now.run(held), &sc);
    json est = json::object();
    for (int e : indices(cur_cat, sl)) {
      const EffectInfo& f = now.effects()[e];
      std::vector<double> v;
      for (int i = 0; i < f.n; ++i)
        if (f.prior[i] > 0 || f.kind == EffectKind::kNoise) v.push_back(held.eff_val[f.offset - EnF::kE + i]);
      est[f.name] = v;
    }
    const json left = unexplainedJson(base, res, true);
    steps.push_back({{"added", cands[static_cast<std::size_t>(best)].name},
                     {"heldout",
                      {{"with", best_held["with"]},
                       {"folds", best_held["folds"]},
                       {"folds_failed", best_held["folds_failed"]},
                       {"before", best_held["before"]},
                       {"after", best_held["after"]}}},
                     {"paired", best_held["paired"]},
                     {"score_z", best_s.z},
                     {"estimate", est},
                     {"explained_fraction", left["explained_fraction"]},
                     {"left", left["features"]}});
  }
  *final_with = cur_names;
  // The final model against the model as it was: one step's comparison is already that;
  // after several, one more.
  json overall = nullptr;
  if (steps.size() == 1) {
    overall = {{"before", steps[0]["heldout"]["before"]}, {"after", steps[0]["heldout"]["after"]},
               {"paired", steps[0]["paired"]}};
  } else if (steps.size() > 1) {
    const FeatureSlots sl = slotsFor(cur_terms, base, tc);
    EnF as_was(log, opt), fin(log, opt, sl);
    std::string err;
    if (as_was.prepare(&err) && fin.prepare(&err)) {
      const HeldoutResult h = compareModels(as_was, {}, fin, indices(cur_cat, sl), cur_names, opt, leave_out);
      overall = {{"before", h.json["before"]}, {"after", h.json["after"]}, {"paired", h.json["paired"]}};
    }
  }
  return {{"steps", steps},
          {"final_with", cur_names},
          {"overall", overall},
          {"tried", tried},
          {"rule", "a step is kept when its held-out pose error (with truth; else, or when it adds only noise "
                   "effects, the NLL) falls with paired z <= -2, the strongest fall first; candidates: the best "
                   "named catalogue effect, the features the residuals still depend on, the forms the dependence "
                   "findings propose, the step at a change point"}};
}

template <template <typename> class DriveT>
json confirmHeldout(const Engine<DriveT>& en, int e, const DiagnoseOptions& opt,
                    const std::vector<std::uint8_t>* leave_out) {
  const std::string name = en.effects()[static_cast<std::size_t>(e)].name;
  const HeldoutResult h = compareHeldout(en, {}, {e}, {name}, opt, leave_out);
  const Score d = decidingScore(h.json, en.effects()[static_cast<std::size_t>(e)].kind == EffectKind::kNoise);
  const double worst = worstZ(h.json);
  // Not contradicted: the deciding held-out error (the pose error with truth, else and for a
  // noise effect the NLL) falls (z < 0) and none rises with z >= +2. A weak true effect may
  // not reach z <= -2 on held-out data, and the likelihood named it; an effect that improves
  // nothing held out, or makes one error clearly worse, is not named.
  const bool kept = d.z < 0 && worst < kWorseZ;
  return {{"effect", name}, {"paired", h.json["paired"]}, {"z", d.z}, {"worst_z", worst}, {"confirmed", kept}};
}

template <template <typename> class DriveT>
json rivalTest(const Engine<DriveT>& en, int e, const Residuals& base, const DiagnoseOptions& opt,
               const std::vector<std::uint8_t>* leave_out) {
  using EnF = Engine<DriveT, Featured>;
  const auto& fx = en.effects();
  const int ne = static_cast<int>(fx.size());
  const EffectKind kind = fx[static_cast<std::size_t>(e)].kind;
  if (kind == EffectKind::kNoise) return nullptr;
  // The features of the other kind: beam terms rival a motion effect, motion terms a
  // measurement effect (a host-only term, which no feature effect carries, is left out).
  const bool want_beam = kind == EffectKind::kMotion;
  const std::vector<Term>& terms = want_beam ? base.beam_terms : base.motion_terms;
  const Selection sel = carriedSelection(want_beam ? base.beam : base.motion,
                                         want_beam ? base.beam_sel : base.motion_sel, terms);
  std::vector<Term> rival;
  std::string name;
  for (int j : sel.terms) {
    const Term& t = terms[static_cast<std::size_t>(j)];
    if (withToken(t).empty() || rival.size() >= FeatureSlots::kMax) continue;
    rival.push_back(t);
    name += (name.empty() ? "" : ",") + withToken(t);
  }
  if (rival.empty()) return nullptr;
  const FeatureSlots sl = slotsFor(rival, base);
  EnF cat(en.log(), opt), feat(en.log(), opt, sl);
  std::string err;
  if (!cat.prepare(&err) || !feat.prepare(&err)) return nullptr;
  const HeldoutResult h =
      compareModels(cat, {e}, feat, {want_beam ? ne + 1 : ne}, {fx[static_cast<std::size_t>(e)].name + " vs " + name}, opt,
                    leave_out);
  // A mimic fits the beams about as well as the true form (that is what makes it one), so the
  // beams' NLL may not decide the kind; where the log has truth, the held-out pose error
  // does: the form of the right kind moves the robot where it went.
  const Score d = decidingScore(h.json);
  return {{"effect", fx[static_cast<std::size_t>(e)].name},
          {"rival", name},
          {"paired", h.json["paired"]},
          {"decided_by", d.by},
          {"z", d.z},
          {"won", d.ok}};
}

bool writeSuggestion(const std::string& dir, const std::vector<Term>& terms, const std::vector<double>& coef,
                     const std::vector<double>& sigma, std::string* error) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string path = (std::filesystem::path(dir) / "discovered_effect.hpp").string();
  std::ofstream f(path);
  f << "// A starting point written by `odoerr diagnose --suggest` from the features that residual\n"
       "// discovery found (docs/writing-an-effect.md walks through finishing it): check the\n"
       "// physics, name it, give it a prior and a reference size, test its Jacobians, then add it\n"
       "// to the catalogue. Without this step, the same finding runs in the firmware as a\n"
       "// configured FeatureMotion / FeatureRange (effects/feature_effects.hpp).\n"
       "#pragma once\n\n#include \"odoerr/effects/catalogue.hpp\"\n#include \"odoerr/effects/features.hpp\"\n\n"
       "namespace odoerr::effects {\n\n";
  std::vector<std::size_t> motion, beam;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    if (terms[i].kind == Term::Kind::kMotion) motion.push_back(i);
    if (terms[i].kind == Term::Kind::kBeam) beam.push_back(i);
  }
  auto enumName = [](const std::string& n) {
    std::string out = "k";
    bool up = true;
    for (char c : n) {
      if (c == '_') {
        up = true;
        continue;
      }
      out += up ? static_cast<char>(std::toupper(static_cast<unsigned char>(c))) : c;
      up = false;
    }
    return out;
  };
  auto targetEnum = [&](const Term& t) { return "MotionTarget::" + enumName(t.target()); };
  if (!motion.empty()) {
    f << "/// The motion error found:\n";
    for (std::size_t i : motion) f << "///   " << terms[i].words(coef[i], sigma[i]) << "\n";
    f << "struct DiscoveredMotion : NominalZero<DiscoveredMotion> {\n"
         "  static constexpr EffectKind kKind = EffectKind::kMotion;\n"
         "  static constexpr int kParams = " << motion.size() << ";\n"
         "  static constexpr const char* kName = \"discovered_motion\";\n"
         "  static constexpr const char* kParamNames[kParams] = {";
    for (std::size_t k = 0; k < motion.size(); ++k) f << (k ? ", " : "") << "\"c_" << terms[motion[k]].name() << "\"";
    f << "};\n  static constexpr const char* kDescription = \"TODO: the physical cause, in one sentence\";\n"
         "  static constexpr double kPriorSigma[kParams] = {";
    for (std::size_t k = 0; k < motion.size(); ++k) f << (k ? ", " : "") << 3 * std::abs(coef[motion[k]]);
    f << "};  // TODO: how large it may plausibly be\n  static constexpr double kReference[kParams] = {";
    for (std::size_t k = 0; k < motion.size(); ++k) f << (k ? ", " : "") << std::abs(coef[motion[k]]);
    f << "};\n  static constexpr bool kUsesHeading = true;  // the features may read the heading\n"
         "  static constexpr bool kHistory = true;      // ... and the motion's history (accelerations)\n"
         "  double wheelbase = 0.5, xc = 0, yc = 0;  // set where the model is composed\n"
         "  template <typename S>\n"
         "  Increment<S> apply(const Increment<S>& in, const S* p, const HistoryMotionContext<S>& ctx,\n"
         "                     Eigen::Matrix<S, 3, 3>& d_in, Eigen::Matrix<S, 3, kParams>& d_p) const {\n"
         "    startJacobians(d_in, d_p);\n    Increment<S> out = in;\n"
         "    auto add = [&](int i, MotionFeature feat, MotionTarget target) {\n"
         "      const FeatureValue<S> v = motionFeature(feat, in.rho, in.theta, ctx, S(wheelbase), S(xc), S(yc));\n"
         "      S dir[3];\n      motionTargetDirection(target, ctx, S(wheelbase), dir);\n"
         "      out.rho += p[i] * v.f * dir[0];\n      out.theta += p[i] * v.f * dir[1];\n      out.side += p[i] * v.f * dir[2];\n"
         "      for (int r = 0; r < 3; ++r) {\n        d_p(r, i) = v.f * dir[r];\n"
         "        d_in(r, 0) += p[i] * v.d_rho * dir[r];\n        d_in(r, 1) += p[i] * v.d_th * dir[r];\n      }\n    };\n";
    for (std::size_t k = 0; k < motion.size(); ++k)
      f << "    add(" << k << ", MotionFeature::" << enumName(terms[motion[k]].name()) << ", " << targetEnum(terms[motion[k]])
        << ");  // estimated " << coef[motion[k]] << "\n";
    f << "    return out;\n  }\n};\n\n";
  }
  if (!beam.empty()) {
    f << "/// The range error found (a measurement effect: see RangeBias in measurement_effects.hpp\n"
         "/// for the hook's form):\n";
    for (std::size_t i : beam)
      f << "///   range += c x " << terms[i].name() << ", estimated c = " << coef[i] << " +- " << sigma[i] << "\n";
    f << "/// Until it is written as a struct, compose FeatureRange<N> with these slots configured.\n\n";
  }
  for (std::size_t i = 0; i < terms.size(); ++i) {
    if (terms[i].kind == Term::Kind::kReversal)
      f << "// " << terms[i].words(coef[i], sigma[i]) << ": the catalogue's wheel_backlash / backlash carry this form.\n";
    if (terms[i].kind == Term::Kind::kTime)
      f << "// " << terms[i].words(coef[i], sigma[i]) << ": the core does not see the time; model it on the host.\n";
  }
  f << "\n}  // namespace odoerr::effects\n";
  if (!f) {
    *error = "cannot write '" + path + "'";
    return false;
  }
  return true;
}

template json autoSearch<SyncDrive>(const Engine<SyncDrive>&, const Ranking<SyncDrive>&, const Residuals&, const Scales&,
                                    const DiagnoseOptions&, std::vector<std::string>*,
                                    const std::vector<std::uint8_t>*, double, const json&);
template json autoSearch<DiffDrive>(const Engine<DiffDrive>&, const Ranking<DiffDrive>&, const Residuals&, const Scales&,
                                    const DiagnoseOptions&, std::vector<std::string>*,
                                    const std::vector<std::uint8_t>*, double, const json&);
template json confirmHeldout<SyncDrive>(const Engine<SyncDrive>&, int, const DiagnoseOptions&,
                                       const std::vector<std::uint8_t>*);
template json confirmHeldout<DiffDrive>(const Engine<DiffDrive>&, int, const DiagnoseOptions&,
                                       const std::vector<std::uint8_t>*);
template json rivalTest<SyncDrive>(const Engine<SyncDrive>&, int, const Residuals&, const DiagnoseOptions&,
                                   const std::vector<std::uint8_t>*);
template json rivalTest<DiffDrive>(const Engine<DiffDrive>&, int, const Residuals&, const DiagnoseOptions&,
                                   const std::vector<std::uint8_t>*);

}  // namespace odoerr::sim::diag
