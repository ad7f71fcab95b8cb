#include "odoerr/sim/paper_experiment.hpp"

#include "odoerr/sim/bound.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

namespace odoerr::sim {

const char* toString(DriveKind d) { return d == DriveKind::kSync ? "sync" : "diff"; }

namespace {

template <template <typename> class DriveT>
CaseResult aggregate(const std::vector<Trace>& traces, const SimConfig& cfg, NonSysStart start) {
  using D = DriveT<double>;
  using L = TraceLayout<D>;
  PaperSim<D> sim(cfg, 0);
  const auto truth_p = sim.trueParams();
  const auto truth_k = sim.trueNonSys();
  CaseResult c;
  c.start = start;
  for (int i = 0; i < L::kP; ++i) c.names.emplace_back(D::kParamNames[i]);
  for (int i = 0; i < L::kM; ++i) c.names.emplace_back(D::kNonSysNames[i]);
  const std::size_t records = traces.front().distance_m.size();
  const double n = double(traces.size());
  c.distance_m = traces.front().distance_m;
  c.params.assign(records, std::vector<Stat>(L::kP + L::kM));
  for (std::size_t r = 0; r < records; ++r) {
    for (int q = 0; q < L::kP + L::kM; ++q) {
      Stat& s = c.params[r][q];
      s.truth = q < L::kP ? truth_p[q] : truth_k[q - L::kP];
      double sum = 0, sum_sig = 0, sq_err = 0;
      for (const Trace& t : traces) {
        const double v = t.values[r * t.width + L::kValue + q];
        sum += v;
        sum_sig += t.values[r * t.width + L::kSigma + q];
        sq_err += (v - s.truth) * (v - s.truth);
      }
      s.mean = sum / n;
      double var = 0;
      for (const Trace& t : traces) {
        const double v = t.values[r * t.width + L::kValue + q];
        var += (v - s.mean) * (v - s.mean);
      }
      // The paper's accuracy: population std over runs / mean * 100.
      s.accuracy_pct = std::sqrt(var / n) / std::abs(s.mean) * 100.0;
      s.rmse = std::sqrt(sq_err / n);
      s.sigma_mean = sum_sig / n;
    }
    double p2 = 0, h2 = 0, ps = 0, hs = 0;
    for (const Trace& t : traces) {
      const double* row = &t.values[r * t.width];
      p2 += row[L::kPosErr] * row[L::kPosErr];
      h2 += row[L::kHeadErr] * row[L::kHeadErr];
      ps += row[L::kPosSigma];
      hs += row[L::kHeadSigma];
    }
    c.pos_rms_m.push_back(std::sqrt(p2 / n));
    c.heading_rms_rad.push_back(std::sqrt(h2 / n));
    c.pos_sigma_mean_m.push_back(ps / n);
    c.heading_sigma_mean_rad.push_back(hs / n);
  }
  for (const Trace& t : traces) {
    const double* row = &t.values[(records - 1) * t.width];
    std::vector<double> v(L::kP + L::kM), sg(L::kP + L::kM);
    for (int q = 0; q < L::kP + L::kM; ++q) {
      v[q] = row[L::kValue + q];
      sg[q] = row[L::kSigma + q];
    }
    c.final_values.push_back(v);
    c.final_sigmas.push_back(sg);
    c.final_pos_err_m.push_back(row[L::kPosErr]);
    c.final_heading_err_rad.push_back(row[L::kHeadErr]);
  }
  for (const Trace& t : traces) {
    c.beams_used += t.beams_used;
    c.gated += t.gated;
    c.grazing += t.grazing;
    c.too_close += t.too_close;
    c.no_return += t.no_return;
    c.rejected += t.rejected;
    c.of_updates += t.of_updates;
    c.of_rejected += t.of_rejected;
    c.of_clamped += t.of_clamped;
  }
  return c;
}

template <template <typename> class DriveT>
void runAll(const PaperOptions& opt, PaperResult& res) {
  const NonSysStart starts[2] = {NonSysStart::kSmall, NonSysStart::kLarge};
  const int total = 2 * opt.runs;
  std::vector<Trace> traces(static_cast<std::size_t>(total));
  std::atomic<int> next{0};
  std::atomic<int> done{0};
  auto worker = [&]() {
    for (int job = next++; job < total; job = next++) {
      const int run = job % opt.runs;
      const NonSysStart st = starts[job / opt.runs];
      traces[job] = runDrive<double, DriveT>(opt.sim, opt.seed + std::uint64_t(run), st, opt.setup,
                                             opt.record_every, nullptr, opt.of, opt.ml);
      ++done;
    }
  };
  const int nthreads = std::max(1, std::min(opt.threads, total));
  std::vector<std::thread> pool;
  for (int i = 0; i < nthreads; ++i) pool.emplace_back(worker);
  int reported = -1;
  while (true) {
    const int d = done.load();
    if (d != reported && opt.progress) opt.progress(d, total);
    reported = d;
    if (d >= total) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  for (auto& t : pool) t.join();
  for (int s = 0; s < 2; ++s) {
    std::vector<Trace> part(traces.begin() + s * opt.runs, traces.begin() + (s + 1) * opt.runs);
    res.cases.push_back(aggregate<DriveT>(part, opt.sim, starts[s]));
  }
}

}  // namespace

namespace {
/// The bound at every record of the cases: run 0's drive (seed opt.seed), a bound record
/// every record_every cycles, which are the cases' records after the first (distance 0).
void addBound(const PaperOptions& opt, PaperResult* res) {
  const auto t0 = std::chrono::steady_clock::now();
  BoundOptions bo;
  bo.every_cycles = opt.record_every;
  BoundResult br;
  std::string err;
  if (!boundOfSimulatedDrive(opt.drive, opt.sim, opt.seed, opt.setup, bo, &br, &err)) {
    throw std::runtime_error("the bound on the nominal drive: " + err);
  }
  const std::size_t records = res->cases.front().distance_m.size();
  const std::size_t params = res->cases.front().names.size();
  res->bound_pct.assign(records, std::vector<double>(params, std::nan("")));
  res->bound_pct_joint = res->bound_pct;
  res->bound_pct_known = res->bound_pct;
  // One record of a table: the systematic parameters' bounds, then K's.
  auto fill = [](std::vector<double>* out, const std::vector<BoundValue>& sys, const std::vector<BoundValue>& nonsys) {
    std::size_t q = 0;
    for (const auto* vs : {&sys, &nonsys}) {
      for (const auto& v : *vs) (*out)[q++] = v.bound_pct >= 0 ? v.bound_pct : std::nan("");
    }
  };
  // bound_pct: delta's with K known (the information the AKF's mean model carries), K's
  // with delta unknown, as the AKF estimates it (the K block of the joint information's
  // inverse). bound_pct_known: each with the others known.
  auto row = [&](std::size_t r, const BoundPoint& bp) {
    fill(&res->bound_pct[r], bp.systematic, bp.nonsystematic_delta_unknown);
    fill(&res->bound_pct_known[r], bp.systematic, bp.nonsystematic);
    fill(&res->bound_pct_joint[r], bp.systematic_joint, bp.nonsystematic_delta_unknown);
  };
  // Records: cycle 0, then every record_every cycles, and the last cycle when steps is not
  // a multiple (runDrive's); the bound's along-path records are the multiples.
  for (std::size_t r = 1; r < records && r - 1 < br.along.size(); ++r) row(r, br.along[r - 1]);
  if (opt.sim.steps % opt.record_every != 0) row(records - 1, br.final_point);
  res->bound_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

PaperResult runPaperExperiment(const PaperOptions& opt) {
  if (opt.runs <= 0) throw std::invalid_argument("--runs must be a positive integer");
  if (opt.record_every <= 0) throw std::invalid_argument("record interval must be positive");
  if (opt.sim.steps <= 0) throw std::invalid_argument("the drive needs at least one cycle");
  PaperResult res;
  res.drive = opt.drive;
  res.of = opt.of;
  res.ml = opt.ml;
  res.figure_eight = opt.sim.figure_eight;
  res.radius_m = opt.sim.radius;
  res.runs = opt.runs;
  const auto t0 = std::chrono::steady_clock::now();
  if (opt.drive == DriveKind::kSync) {
    runAll<SyncDrive>(opt, res);
  } else {
    runAll<DiffDrive>(opt, res);
  }
  res.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  addBound(opt, &res);
  return res;
}

namespace {
std::size_t nearestRecord(const CaseResult& c, double d) {
  std::size_t best = 0;
  for (std::size_t i = 0; i < c.distance_m.size(); ++i) {
    if (std::abs(c.distance_m[i] - d) < std::abs(c.distance_m[best] - d)) best = i;
  }
  return best;
}
}  // namespace

std::string summaryJson(const PaperResult& r) {
  using json = nlohmann::ordered_json;
  json j;
  j["drive"] = toString(r.drive);
  j["runs"] = r.runs;
  j["of"] = toString(r.of);
  if (r.of == OfKind::kMl) {
    j["ml"] = {{"every", r.ml.every},
               {"solve_iters", r.ml.solve_iters},
               {"reset_log", r.ml.reset_log},
               {"inflate", r.ml.inflate},
               {"inflate_held", r.ml.inflate_held},
               {"inflate_cap", std::round(std::exp(r.ml.max_inflate_log) * 1000.0) / 1000.0},
               {"start_inflate_cap", std::round(std::exp(r.ml.max_start_inflate_log) * 1000.0) / 1000.0},
               {"form", toString(r.ml.form)},
               {"discount", r.ml.discount},
               {"discount_above", r.ml.discount_above},
               {"credit", r.ml.credit},
               {"reset_keep", r.ml.reset_keep},
               {"shift", r.ml.scale_shift ? "scale" : "line"},
               {"deflate", r.ml.deflate},
               {"heading_scale", r.ml.heading_scale}};
  }
  j["path"] = r.figure_eight ? "eight" : "circle";
  j["radius_m"] = r.radius_m;
  j["wall_time_s"] = std::round(r.wall_time_s * 1000.0) / 1000.0;
  j["bound"] = {{"what", "Cramér-Rao bound (odoerr bound) on run 0's drive, 100 sigma / true value"},
                {"wall_time_s", std::round(r.bound_time_s * 1000.0) / 1000.0}};
  json cases = json::array();
  for (const CaseResult& c : r.cases) {
    json jc;
    jc["init"] = toString(c.start);
    json cps = json::array();
    for (double d : {5.0, 10.0, 20.0, 30.0}) {
      const std::size_t i = nearestRecord(c, d);
      if (std::abs(c.distance_m[i] - d) > 0.5) continue;  // drive shorter than the checkpoint
      json cp;
      cp["distance_m"] = d;
      json params = json::object();
      for (std::size_t q = 0; q < c.names.size(); ++q) {
        const Stat& s = c.params[i][q];
        auto bound = [&](const std::vector<std::vector<double>>& t) {
          const double b = t.empty() ? std::nan("") : t[i][q];
          return std::isfinite(b) ? json(b) : json(nullptr);
        };
        // Sigma honesty: the mean reported sigma over the spread (population std) across
        // runs; null when the spread is zero (one run) or undefined.
        const double spread = s.accuracy_pct / 100.0 * std::abs(s.mean);
        const double ratio = spread > 0 && std::isfinite(spread) ? s.sigma_mean / spread : std::nan("");
        params[c.names[q]] = {{"true", s.truth},
                              {"mean", s.mean},
                              {"accuracy_pct", s.accuracy_pct},
                              {"bound_pct", bound(r.bound_pct)},
                              {"bound_pct_joint", bound(r.bound_pct_joint)},
                              {"bound_pct_known", bound(r.bound_pct_known)},
                              {"rmse", s.rmse},
                              {"sigma_mean", s.sigma_mean},
                              {"sigma_ratio", std::isfinite(ratio) ? json(ratio) : json(nullptr)}};
      }
      cp["params"] = params;
      cp["pose_rms"] = {{"position_m", c.pos_rms_m[i]}, {"orientation_rad", c.heading_rms_rad[i]}};
      cps.push_back(cp);
    }
    jc["checkpoints"] = cps;
    cases.push_back(jc);
  }
  j["cases"] = cases;
  return j.dump(2) + "\n";
}

std::string paperCsv(const PaperResult& r) {
  std::string out = "init,distance_m";
  const CaseResult& c0 = r.cases.front();
  for (const std::string& n : c0.names) {
    for (const char* suffix : {"_mean", "_accuracy_pct", "_rmse", "_sigma_mean", "_true", "_bound_pct"}) {
      out += "," + n + suffix;
    }
  }
  out += ",pos_rms_m,heading_rms_rad,pos_sigma_mean_m,heading_sigma_mean_rad\n";
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.9g", v);
    out += buf;
  };
  for (const CaseResult& c : r.cases) {
    for (std::size_t i = 0; i < c.distance_m.size(); ++i) {
      out += toString(c.start);
      num(c.distance_m[i]);
      for (std::size_t q = 0; q < c.params[i].size(); ++q) {
        const Stat& s = c.params[i][q];
        num(s.mean);
        num(s.accuracy_pct);
        num(s.rmse);
        num(s.sigma_mean);
        num(s.truth);
        num(r.bound_pct.empty() ? std::nan("") : r.bound_pct[i][q]);
      }
      num(c.pos_rms_m[i]);
      num(c.heading_rms_rad[i]);
      num(c.pos_sigma_mean_m[i]);
      num(c.heading_sigma_mean_rad[i]);
      out += "\n";
    }
  }
  return out;
}

std::string runsCsv(const PaperResult& r, std::uint64_t seed0) {
  std::string out = "init,run,seed";
  const CaseResult& c0 = r.cases.front();
  for (const std::string& n : c0.names) out += "," + n;
  for (const std::string& n : c0.names) out += "," + n + "_sigma";
  out += ",pos_err_m,heading_err_rad\n";
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof buf, ",%.9g", v);
    out += buf;
  };
  for (const CaseResult& c : r.cases) {
    for (std::size_t k = 0; k < c.final_values.size(); ++k) {
      out += toString(c.start);
      out += "," + std::to_string(k) + "," + std::to_string(seed0 + k);
      for (double v : c.final_values[k]) num(v);
      for (double v : c.final_sigmas[k]) num(v);
      num(c.final_pos_err_m[k]);
      num(c.final_heading_err_rad[k]);
      out += "\n";
    }
  }
  return out;
}

std::string healthJson(const PaperResult& r) {
  using json = nlohmann::ordered_json;
  json j;
  j["drive"] = toString(r.drive);
  j["runs"] = r.runs;
  json cases = json::array();
  for (const CaseResult& c : r.cases) {
    cases.push_back({{"init", toString(c.start)},
                     {"beams_used", c.beams_used},
                     {"beams_gated", c.gated},
                     {"beams_grazing", c.grazing},
                     {"beams_too_close", c.too_close},
                     {"beams_no_return_or_no_hit", c.no_return},
                     {"updates_rejected", c.rejected},
                     {"of_updates", c.of_updates},
                     {"of_rejected", c.of_rejected},
                     {"of_clamped_at_floor", c.of_clamped}});
  }
  j["cases"] = cases;
  return j.dump(2) + "\n";
}

}  // namespace odoerr::sim
