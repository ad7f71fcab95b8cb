#include "power.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "excitation.hpp"  // adviceFor
#include "odoerr/sim/stats.hpp"

namespace odoerr::sim::diag {

namespace {
using json = nlohmann::ordered_json;

std::string sig3(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}
}  // namespace

json detectionPower(const std::vector<EffectInfo>& fx, const std::vector<Candidate>& cand, long n_innov,
                    bool has_laser) {
  const double ln_n = n_innov > 1 ? std::log(double(n_innov)) : 0.0;
  json families = json::array();
  for (std::size_t e = 0; e < fx.size() && e < cand.size(); ++e) {
    const EffectInfo& f = fx[e];
    const Candidate& c = cand[e];
    json fam = {{"family", f.name},
                {"kind", f.kind == EffectKind::kMotion  ? "motion"
                         : f.kind == EffectKind::kNoise ? "noise"
                                                        : "measurement"}};
    // A parameter the drive informs, with a sigma to scale: the test's degrees of freedom.
    auto informed = [&c](int i) {
      return i < static_cast<int>(c.informed.size()) && c.informed[i] && std::isfinite(c.sig[i]) && c.sig[i] > 0;
    };
    int k = 0;
    for (int i = 0; i < f.n; ++i) k += informed(i) ? 1 : 0;
    std::string why;
    if (f.kind == EffectKind::kNoise) {
      why = "a noise effect is tested on its likelihood profile, which gives no sigma to scale";
    } else if (f.kind == EffectKind::kMeasurement && !has_laser) {
      why = "needs a laser; the log has none";
    } else if (k == 0) {
      why = std::string("not excited by this drive: ") + adviceFor(f.name);
    }
    json params = json::array();
    double threshold = 0.0, lambda = 0.0;
    if (why.empty()) {
      threshold = std::max({chiSquareQuantile(1.0 - kRankAlphaLr, k), k * ln_n, chiSquareQuantile(1.0 - kRankAlphaWald, k)});
      lambda = noncentralityForPower(k, threshold, kDetectionPower);
    }
    for (int i = 0; i < f.n; ++i) {
      json p = {{"name", f.pnames[i]}, {"reference_size", f.ref[i]}};
      if (why.empty() && informed(i)) {
        const double mde = c.sig[i] * std::sqrt(lambda);
        p["min_detectable"] = mde;
        p["sigma"] = c.sig[i];
        p["over_reference_size"] = f.ref[i] > 0 ? json(mde / f.ref[i]) : json(nullptr);
      } else {
        p["min_detectable"] = nullptr;
        p["why"] = why.empty() ? "not excited by this drive (the parameter's sigma stays at its prior)" : why;
      }
      params.push_back(p);
    }
    fam["excited"] = why.empty();
    if (!why.empty()) fam["why"] = why;
    fam["informed_params"] = k;
    fam["threshold"] = why.empty() ? json(threshold) : json(nullptr);
    fam["noncentrality"] = why.empty() ? json(lambda) : json(nullptr);
    fam["parameters"] = params;
    families.push_back(fam);
  }
  return {{"power", kDetectionPower},
          {"rule", "the ranking's: likelihood ratio beyond chi2_k(1 - 1e-3) and k ln n, Wald beyond chi2_k(1 - 1e-2)"},
          {"n_innovations", n_innov},
          {"families", families}};
}

namespace {
/// The unit of a term's coefficient: its target's unit over its feature's.
std::string coefUnit(const Term& t) {
  auto over = [](const std::string& num, const std::string& den) {
    if (den == "1") return num;
    return den.find_first_of("/*") == std::string::npos ? num + "/" + den : num + "/(" + den + ")";
  };
  switch (t.kind) {
    case Term::Kind::kBeam: return over("m", effects::beamFeatureUnit(t.bf));
    case Term::Kind::kTime: return "m/s";
    case Term::Kind::kReversal: return std::string(effects::motionTargetUnit(t.mt)) + " per reversal";
    case Term::Kind::kMotion: break;
  }
  return over(effects::motionTargetUnit(t.mt), effects::motionFeatureUnit(t.mf));
}

json termsPower(const Design& d, const std::vector<Term>& terms) {
  std::vector<double> sig;
  const std::vector<double> mde = minDetectableCoefs(d, SelectOptions{}, kDetectionPower, &sig);
  json out = json::array();
  for (std::size_t k = 0; k < mde.size() && k < terms.size(); ++k) {
    const Term& t = terms[k];
    json row = {{"term", t.name() + "@" + t.target()}, {"frame", t.frame()}, {"unit", coefUnit(t)}};
    if (std::isfinite(mde[k])) {
      row["min_detectable"] = mde[k];
      row["sigma"] = sig[k];
    } else {
      row["min_detectable"] = nullptr;
      row["why"] = "not excited by this drive (the term's column is zero or follows the drive parameters')";
    }
    out.push_back(row);
  }
  return out;
}
}  // namespace

json featurePower(const Residuals& base) {
  const SelectOptions so;
  char rule[160];
  std::snprintf(rule, sizeof rule,
                "discovery's: a term's cluster-robust z beyond %.1f and a %.0f %% fall of the cross-validated misfit",
                so.z_min, 100 * so.min_gain);
  return {{"power", kDetectionPower},
          {"rule", rule},
          {"motion", {{"rows", base.motion.x.rows()}, {"terms", termsPower(base.motion, base.motion_terms)}}},
          {"beam", {{"rows", base.beam.x.rows()}, {"terms", termsPower(base.beam, base.beam_terms)}}}};
}

std::string nothingLargerThan(const json& power) {
  // Per family, the largest of its parameters' sizes: no parameter larger than that.
  std::string sizes, not_excited, noise;
  for (const json& fam : power["families"]) {
    if (fam["kind"] == "noise") {
      noise += (noise.empty() ? "" : ", ") + fam["family"].get<std::string>();
      continue;
    }
    if (!fam["excited"].get<bool>()) {
      not_excited += (not_excited.empty() ? "" : ", ") + fam["family"].get<std::string>();
      continue;
    }
    double worst = 0.0;
    std::string which, idle;
    int n = 0, n_idle = 0;
    for (const json& p : fam["parameters"]) {
      if (p["min_detectable"].is_null()) {
        idle += (idle.empty() ? "" : ", ") + p["name"].get<std::string>();
        ++n_idle;
        continue;
      }
      ++n;
      if (p["min_detectable"].get<double>() > worst) {
        worst = p["min_detectable"].get<double>();
        which = p["name"].get<std::string>();
      }
    }
    std::string item = fam["family"].get<std::string>() + (n == 1 ? "." + which : "") + " " + sig3(worst);
    if (n > 1) item += " (any of " + std::to_string(n) + " parameters)";
    if (n_idle > 3) {
      item += " (" + std::to_string(n_idle) + " more not excited)";
    } else if (n_idle > 0) {
      item += " (" + idle + " not excited)";
    }
    sizes += (sizes.empty() ? "" : ", ") + item;
  }
  std::string s = sizes.empty() ? "no effect family was excited enough to bound"
                                : "nothing larger than " + sizes + " (" +
                                      sig3(100 * power["power"].get<double>()) + " % power)";
  if (!not_excited.empty()) s += "; not excited by this drive: " + not_excited;
  if (power.contains("features")) {
    int bounded = 0, idle = 0;
    for (const char* design : {"motion", "beam"})
      for (const json& t : power["features"][design]["terms"]) (t["min_detectable"].is_null() ? idle : bounded) += 1;
    s += "; feature terms: " + std::to_string(bounded) + " bounded (detection_power.features)";
    if (idle > 0) s += ", " + std::to_string(idle) + " not excited";
  }
  if (!noise.empty()) s += "; no size stated for " + noise + " (tested on its likelihood profile)";
  return s;
}

}  // namespace odoerr::sim::diag
