// feature_effects: the feature effects on the target. Built with the firmware's flags
// (float, -fno-exceptions, -Wdouble-promotion, -Werror) and linked with the heap trap, so
// a build proves they need no heap; run under QEMU, it drives a model with a
// FeatureMotion<4> and a FeatureRange<4> slot configured by name around a square room and
// exits 0 when the filter stayed healthy and finite.
// The firmware's own model does not carry the feature effects: its cycle (footprint.json)
// is unchanged by them.
#include "odoerr/effects/catalogue.hpp"  // priorSigma(effect, i)
#include "odoerr/effects/feature_effects.hpp"
#include "odoerr/estimator.hpp"

#include <new>

namespace {

using namespace odoerr;
using FM = effects::FeatureMotion<4>;
using FR = effects::FeatureRange<4>;
using M = Model<DiffDrive<float>, FM, FR>;
using Est = Estimator<M>;
static_assert(M::kStates == 3 + 3 + 4 + 4, "pose, drive, four + four coefficients");
static_assert(M::kUsesHeading, "the filter fills the heading for it");

Est::MapT g_map;
Est::LaserT g_laser;
alignas(Est) unsigned char g_est_mem[sizeof(Est)];  // static storage, no heap

}  // namespace

int main() {
  if (!(g_map.add({0, 0, 10, 0}) && g_map.add({10, 0, 10, 10}) && g_map.add({10, 10, 0, 10}) &&
        g_map.add({0, 10, 0, 0}))) {
    return 1;
  }
  if (!g_laser.init(LaserConfig<float>{})) return 2;
  DiffDrive<float> drive;
  drive.wheelbase = 0.5f;
  M model(drive);
  FM& fm = std::get<FM>(model.effects);
  fm.wheelbase = 0.5;
  fm.xc = 5;
  fm.yc = 5;
  effects::MotionFeature f;
  effects::MotionTarget t;
  effects::BeamFeature b;
  if (!effects::parseMotionFeature("ds_R_speed", &f) || !effects::parseMotionTarget("wheel_R", &t) ||
      !effects::parseBeamFeature("inv_cos_inc", &b)) {
    return 3;
  }
  if (!fm.configure(0, f, t, 0.1, 0.01) || !std::get<FR>(model.effects).configure(0, b, 0.1, 0.01)) return 4;
  Est* est = new (g_est_mem) Est(model, g_map, g_laser);
  M::StateVec x0 = M::StateVec::Zero();
  x0[0] = 5.0f;
  x0[1] = 2.75f;
  M::setNominal(x0);
  M::StateVec sig = M::StateVec::Constant(1e-3f);
  for (int i = 0; i < 4; ++i) {
    sig[M::offsetOf<FM>() + i] = static_cast<float>(effects::priorSigma(fm, i));
    sig[M::offsetOf<FR>() + i] = static_cast<float>(effects::priorSigma(std::get<FR>(model.effects), i));
  }
  Est::OfT::KVec k0 = Est::OfT::KVec::Constant(1e-6f);
  est->init(x0, sig.cwiseAbs2().asDiagonal(), k0, (k0 * 0.1f).cwiseAbs2().asDiagonal());
  est->freezeNonSystematic(true);
  // a circle of radius 2.25 m around the room's centre; the scans are the map's ranges at
  // the filter's own pose (no truth error: this checks the code runs, not the statistics)
  float ranges[36];
  int used = 0;
  for (int i = 0; i < 400; ++i) {
    const DiffDrive<float>::Input u{0.01f, 0.008f};
    const bool scan = i % 10 == 9;
    if (scan) {
      const Pose<float> p = est->akf().pose();
      const LaserConfig<float>& lc = g_laser.config();
      for (int k = 0; k < 36; ++k) {
        const RayHit<float> hit = g_map.cast(p.x, p.y, p.theta + lc.angle_min + float(k) * lc.angle_inc);
        ranges[k] = hit.hit ? hit.range : 0.0f;
      }
    }
    const CycleResult<float> r = est->cycle(u, 0.02f, scan ? ranges : nullptr, Akf<M>::NoObserver{});
    if (r.predict != Status::kOk) return 5;
    used += r.scan.used;
  }
  if (used < 1000 || !est->akf().state().allFinite()) return 6;
  return 0;
}
