// The rules a log must keep through the host pipeline (the reader, replay, diagnose): never a
// crash, an error that names the file, no number that is not finite in what is reported,
// counts that add up. Shared by the mutation test (test_pipeline_mutations.cpp); a libFuzzer
// target can call the same function.
#pragma once

#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "odoerr/sim/diagnose.hpp"
#include "odoerr/sim/odolog.hpp"
#include "odoerr/sim/replay.hpp"

namespace odoerr::sim::test {

/// "" when every number in j is finite, else the first one's path.
inline std::string firstNonFinite(const nlohmann::ordered_json& j, const std::string& path = "") {
  if (j.is_number_float()) return std::isfinite(j.get<double>()) ? "" : (path.empty() ? "/" : path);
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const std::string w = firstNonFinite(it.value(), path + "/" + it.key());
      if (!w.empty()) return w;
    }
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      const std::string w = firstNonFinite(j[i], path + "/" + std::to_string(i));
      if (!w.empty()) return w;
    }
  }
  return "";
}

/// How far a log went: refused by the reader, refused by replay, answered by replay,
/// refused by diagnose, answered by diagnose.
enum class Reached { kReaderRefused, kReplayRefused, kReplayed, kDiagnoseRefused, kDiagnosed };

/// The text of a log (called FILE in messages) through the reader, replay (into work_dir)
/// and, with `diagnose`, the diagnosis: "" when every rule holds, else the rule broken.
inline std::string checkPipeline(const std::string& text, const std::string& file, const std::string& work_dir,
                                 bool diagnose, Reached* reached = nullptr) {
  Reached dummy;
  Reached& at = reached != nullptr ? *reached : dummy;
  at = Reached::kReaderRefused;
  Odolog log;
  std::string error;
  if (!parseOdolog(text, file, &log, &error)) {
    return error.rfind(file, 0) == 0 ? "" : "the reader's error does not name the file: " + error;
  }
  ReplayOptions ro;
  ro.out_dir = work_dir;
  ReplaySummary sum;
  at = Reached::kReplayRefused;
  if (!replayOdolog(log, ro, &sum, &error)) {
    if (error.empty()) return "replay failed without saying why";
  } else {
    at = Reached::kReplayed;
    if (!std::isfinite(sum.nis_mean)) return "replay: NIS mean not finite";
    if (!std::isfinite(sum.pose_rmse_m) || !std::isfinite(sum.heading_rmse_rad)) return "replay: RMSE not finite";
    for (const ReplayParam& p : sum.params)
      if (!std::isfinite(p.value) || !std::isfinite(p.sigma)) return "replay: parameter " + p.name + " not finite";
    // Every scan and pose fix read is fused or counted late (stamped before the filter's
    // time), all of them unless replay stopped at a loss. Late ones may outnumber fused ones
    // (a log whose only scan precedes its first encoder record).
    const std::size_t scans_seen = sum.scans + sum.scans_late, poses_seen = sum.poses + sum.poses_late;
    if (sum.stopped_when_lost ? (scans_seen > log.scans.size() || poses_seen > log.poses.size())
                              : (scans_seen != log.scans.size() || poses_seen != log.poses.size()))
      return "replay: fused and late records do not add up to the log's";
  }
  if (!diagnose) return "";
  DiagnoseOptions d;
  d.threads = 1;
  nlohmann::ordered_json out;
  if (!diagnoseOdolog(log, d, &out, &error)) {
    at = Reached::kDiagnoseRefused;
    return error.empty() ? "diagnose failed without saying why" : "";
  }
  at = Reached::kDiagnosed;
  if (!out.contains("verdict")) return "diagnose: no verdict";
  const std::string where = firstNonFinite(out);
  return where.empty() ? "" : "diagnose: a number that is not finite at " + where;
}

}  // namespace odoerr::sim::test
