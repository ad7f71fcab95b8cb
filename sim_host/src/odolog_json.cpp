#include "odoerr/sim/odolog_json.hpp"

namespace odoerr::sim {

nlohmann::ordered_json rejectionsJson(const Odolog& log, std::size_t first) {
  using json = nlohmann::ordered_json;
  const OdologLimits& L = log.enc_limits;
  json lim;
  lim["max_speed_mps"] = L.max_speed_mps;
  lim["max_speed_from"] = L.speed_given ? "param max_speed_mps" : "default";
  if (log.drive == "sync") {
    lim["max_steer_rate_radps"] = L.max_steer_rate_radps;
    lim["max_steer_rate_from"] = L.steer_given ? "param max_steer_rate_radps" : "default";
  }
  lim["ticks_per_s"] = {L.ticks_per_s_a, L.ticks_per_s_b};
  lim["margin_ticks"] = L.margin_ticks;
  lim["dt_floor_s"] = L.dt_floor_s;
  lim["synthetic_time"] = L.synthetic_time;
  if (L.synthetic_time) {
    lim["rule"] = "the log's own: 100 x the channel's median nonzero increment (its time stamps do not measure time)";
    lim["median_increment_ticks"] = {L.median_increment_a, L.median_increment_b};
  } else {
    lim["rule"] = "the drive's: ticks per second x max(dt, dt_floor_s), plus the margin";
  }
  json list = json::array();
  for (std::size_t i = 0; i < log.enc_rejected.size() && i < first; ++i) {
    const OdologRejection& r = log.enc_rejected[i];
    list.push_back({{"t", r.t}, {"line", r.line}, {"channel", std::string(1, r.channel)}, {"ticks", r.ticks},
                    {"limit_ticks", r.limit}});
  }
  return {{"count", log.enc_rejected.size()}, {"limits", lim}, {"first", list}};
}

}  // namespace odoerr::sim
