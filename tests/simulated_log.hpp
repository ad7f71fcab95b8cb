// Test helpers of the log suites: a simulated drive as odolog text, a fresh scratch folder.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

#include "odoerr/sim/odolog_writer.hpp"
#include "odoerr/sim/runner.hpp"

namespace odoerr::sim::test {

/// The paper's differential-drive drive of `steps` cycles (seed `seed`), as odolog v1 text.
inline std::string simulatedLog(std::uint64_t seed, int steps) {
  SimConfig cfg;
  cfg.steps = steps;
  FilterSetup setup;
  PaperSim<DiffDrive<double>> header_sim(cfg, seed);
  std::string text = odologHeader(header_sim, seed, setup.sigma_pose_xy, setup.sigma_pose_theta);
  (void)runDrive<double, DiffDrive>(cfg, seed, NonSysStart::kSmall, setup, steps,
                                    [&](const SimStep<DiffDrive<double>>& s) {
                                      appendOdologStep(text, s, cfg.laser.beams);
                                    });
  return text;
}

/// An empty folder odoerr-test-NAME under the system's temporary directory.
inline std::string tempDir(const char* name) {
  const auto d = std::filesystem::temp_directory_path() / ("odoerr-test-" + std::string(name));
  std::filesystem::remove_all(d);
  return d.string();
}

}  // namespace odoerr::sim::test
