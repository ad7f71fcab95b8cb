// odoerr evaluate's calibration: the online estimator (diagnose's engine: the drive
// parameters, K and the chosen catalogue effects free) over calibration logs in order,
// the parameters and their covariance carried from one log to the next, the pose
// re-initialised from each log's init.
#include <cmath>
#include <memory>

#include "diagnose/engine.hpp"
#include "diagnose/model_search.hpp"
#include "odoerr/sim/evaluate.hpp"

namespace odoerr::sim {

using json = nlohmann::ordered_json;

bool calibrateOnLogs(const std::vector<Odolog>& logs, const std::vector<std::string>& with, Calibration* out,
                     std::string* error) {
  using En = diag::Engine<DiffDrive>;
  constexpr int kD = En::kD;
  if (logs.empty()) {
    *error = "no calibration log";
    return false;
  }
  DiagnoseOptions opt;
  opt.with = with;
  En::StateVec x = En::StateVec::Zero();
  En::StateMat p = En::StateMat::Zero();
  En::KVec k = En::KVec::Zero();
  En::KMat pk = En::KMat::Zero();
  bool carried = false;
  Calibration cal;
  for (const Odolog& log : logs) {
    if (log.drive != "diff") {
      *error = log.path + ": odoerr evaluate supports diff-drive logs (this one is '" + log.drive + "')";
      return false;
    }
    En en(log, opt);
    if (!en.prepare(error)) return false;
    diag::WithSpec ws;
    if (!diag::parseWith(with, en.effects(), false, &ws, error)) return false;
    if (ws.automatic || !ws.features.empty()) {
      *error = "--with: evaluate takes catalogue effects only (not auto or feature terms)";
      return false;
    }
    En::RunSpec s = en.nominalSpec(carried ? k : en.initialK(), true);
    for (int e : ws.catalogue) en.freeEffect(&s, e);
    if (carried) {
      s.carry_x = &x;
      s.carry_p = &p;
      s.carry_pk = &pk;
    }
    const En::RunOut r = en.run(s);
    x = r.x;
    p = r.p;
    k = r.k;
    pk = r.pk;
    carried = true;
    json row = {{"log", log.path}};
    for (int i = 0; i < 3; ++i) row[En::Drive::kParamNames[i]] = x[kD + i];
    row["K_w"] = k[0];
    cal.per_log.push_back(row);
    cal.effects = json::object();
    for (int e : ws.catalogue) {
      const auto& f = en.effects()[static_cast<std::size_t>(e)];
      json est = json::array(), sig = json::array();
      for (int i = 0; i < f.n; ++i) {
        est.push_back(x[f.offset + i]);
        sig.push_back(std::sqrt(p(f.offset + i, f.offset + i)));
      }
      cal.effects[f.name] = {{"estimate", est}, {"sigma", sig}};
    }
  }
  cal.c.delta_R = x[kD + 0];
  cal.c.delta_L = x[kD + 1];
  cal.c.delta_d = x[kD + 2];
  for (int i = 0; i < 3; ++i) cal.sigma[i] = std::sqrt(p(kD + i, kD + i));
  cal.k_w = k[0];
  cal.k_w_sigma = std::sqrt(pk(0, 0));
  *out = cal;
  return true;
}

}  // namespace odoerr::sim
