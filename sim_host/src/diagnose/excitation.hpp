// diagnose, the excitation report: how well this drive determines each drive parameter
// and each candidate effect (the sigma it achieves against the prior and a typical size),
// and warnings that say which motion would determine what it leaves open.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine.hpp"
#include "ranking.hpp"

namespace odoerr::sim::diag {

/// Advice for a parameter or effect that the drive cannot determine: the motion that
/// excites it.
const char* adviceFor(const std::string& name);

/// {"parameters": [...], "warnings": [...]} from the free baseline (drive parameters)
/// and each candidate's augmented run. Without a laser, no warning names a measurement
/// effect (no drive could show one).
template <template <typename> class DriveT>
nlohmann::ordered_json excitationReport(const Engine<DriveT>& en, const typename Engine<DriveT>::RunOut& base_free,
                                        const std::vector<Candidate>& cand, bool has_laser);

}  // namespace odoerr::sim::diag
