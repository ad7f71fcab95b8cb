// diagnose, the feature terms of discovery in words: their names, frames and targets,
// the `--with` token that puts one into the model, and the finding in plain physical words.
#include <cmath>
#include <cstdio>

#include "discovery.hpp"

namespace odoerr::sim::diag {

namespace {

using effects::BeamFeature;
using effects::MotionFeature;
using effects::MotionTarget;

}  // namespace

std::string Term::name() const {
  switch (kind) {
    case Kind::kMotion: return effects::motionFeatureName(mf);
    case Kind::kReversal: return mt == MotionTarget::kAlong ? "rev" : (wheel == 0 ? "rev_R" : "rev_L");
    case Kind::kBeam: return effects::beamFeatureName(bf);
    case Kind::kTime: return "t";
  }
  return "?";
}

std::string Term::target() const {
  return kind == Kind::kBeam || kind == Kind::kTime ? "range" : effects::motionTargetName(mt);
}

std::string Term::frame() const {
  if (kind == Kind::kBeam || kind == Kind::kTime) return "beam";
  switch (mt) {
    case MotionTarget::kWorldX:
    case MotionTarget::kWorldY: return "world";
    case MotionTarget::kWheelR: return "wheel_R";
    case MotionTarget::kWheelL: return "wheel_L";
    default: return "robot";
  }
}

std::string Term::words(double c, double sigma) const {
  char pm_buf[80];
  std::snprintf(pm_buf, sizeof pm_buf, " (coefficient %.3g ± %.2g)", c, sigma);
  const std::string pm = pm_buf;
  if (kind == Kind::kTime)
    return fmt("the ranges drift by %.2f mm per minute of the drive (a laser that warms up)", 6e4 * c) + pm;
  if (kind == Kind::kBeam) {
    switch (bf) {
      case BeamFeature::kOne: return fmt("every range reads %.1f mm too long (a range bias)", 1e3 * c) + pm;
      case BeamFeature::kRange: return fmt("ranges read %.3f %% too long per metre of range (a range scale)", 1e2 * c) + pm;
      case BeamFeature::kInvCosInc:
        return fmt("ranges read %.1f mm x (1/cos(incidence) - 1) too long: the error grows on oblique walls", 1e3 * c) + pm;
      case BeamFeature::kAbsInc: return fmt("ranges read %.1f mm per radian of incidence too long", 1e3 * c) + pm;
      case BeamFeature::kInc2: return fmt("ranges read %.1f mm per rad^2 of incidence too long", 1e3 * c) + pm;
      case BeamFeature::kAngleSens:
        return fmt("the beams point %.2f mrad counter-clockwise of where the model casts them (a laser yaw)", 1e3 * c) + pm;
      case BeamFeature::kAlphaAngleSens:
        return fmt("the beam angles are scaled by 1 %+.4f: a beam-angle scale error of the scanner", c) + pm;
      case BeamFeature::kWAngleSens:
        return fmt("the beams lag the robot's rotation by %.1f ms (a time offset seen in turns)", -1e3 * c) + pm;
      case BeamFeature::kV: return fmt("ranges read %.1f mm too long per m/s of forward speed", 1e3 * c) + pm;
      case BeamFeature::kW: return fmt("ranges read %.1f mm too long per rad/s of turn rate", 1e3 * c) + pm;
      case BeamFeature::kAlpha: return fmt("ranges read %.1f mm too long per radian of beam angle", 1e3 * c) + pm;
      case BeamFeature::kAlpha2: return fmt("ranges read %.1f mm too long per rad^2 of beam angle", 1e3 * c) + pm;
      default: break;
    }
    return "range += " + fmt("%.4g", c) + " x " + name() + pm;
  }
  const std::string which = mt == MotionTarget::kWheelR ? "the right wheel" : "the left wheel";
  if (kind == Kind::kReversal) {
    const std::string who = mt == MotionTarget::kAlong ? std::string("the robot") : which;
    return who + fmt(c < 0 ? " loses %.1f mm of travel each time it reverses (gear play)"
                           : " gains %.1f mm of travel each time it reverses", 1e3 * std::abs(c)) + pm;
  }
  const char* more = c > 0 ? "more" : "less";
  switch (mt) {
    case MotionTarget::kWheelR:
    case MotionTarget::kWheelL:
      if (mf == MotionFeature::kDsRSpeed || mf == MotionFeature::kDsLSpeed)
        return which + fmt(" travels %.2f %% ", 1e2 * std::abs(c)) + more + " per m/s of its own speed" + pm;
      if (mf == MotionFeature::kAbsDs) return which + fmt(" travels %.2f mm ", 1e3 * std::abs(c)) + more + " per m the robot drives, either way" + pm;
      break;
    case MotionTarget::kWorldX:
    case MotionTarget::kWorldY: {
      const std::string dir = std::string(c > 0 ? "+" : "-") + (mt == MotionTarget::kWorldX ? "x" : "y");
      if (mf == MotionFeature::kAbsDs)
        return fmt("the robot drifts %.2f cm per m of travel toward ", 1e2 * std::abs(c)) + dir +
               " in the world frame, whatever its heading (a slope, a floor that pushes)" + pm;
      if (mf == MotionFeature::kDt)
        return fmt("the robot drifts %.2f mm per second toward ", 1e3 * std::abs(c)) + dir + " in the world frame" + pm;
      break;
    }
    case MotionTarget::kAlong:
      if (mf == MotionFeature::kCosHeadingDs || mf == MotionFeature::kSinHeadingDs)
        return fmt("the robot travels %.2f %% ", 1e2 * std::abs(c)) + more + " x " +
               (mf == MotionFeature::kCosHeadingDs ? "cos" : "sin") +
               "(heading) than the model says: a scale that depends on where it heads" + pm;
      if (mf == MotionFeature::kAbsDs) return fmt("the robot travels %.2f %% ", 1e2 * std::abs(c)) + more + " forward than the model says, whichever way it drives" + pm;
      if (mf == MotionFeature::kV2) return fmt("the robot travels %.2f %% ", 1e2 * std::abs(c)) + more + " per m/s of speed" + pm;
      if (mf == MotionFeature::kSDs) return fmt("the travel scale drifts by %.3f %% ", 1e4 * std::abs(c)) + more + " per 100 m travelled" + pm;
      if (mf == MotionFeature::kXDs || mf == MotionFeature::kYDs)
        return fmt("the travel scale changes by %.2f %% per m of ", 1e2 * c) + (mf == MotionFeature::kXDs ? "x" : "y") + " (a floor that differs across the room)" + pm;
      break;
    case MotionTarget::kCross:
      if (mf == MotionFeature::kVW) return fmt("the robot slides %.2f mm sideways (left +) per m of travel per rad/s of turn rate", 1e3 * c) + pm;
      if (mf == MotionFeature::kDs) return fmt("the robot drifts %.2f mm sideways (left +) per m of travel", 1e3 * c) + pm;
      if (mf == MotionFeature::kDth) return fmt("the robot's turning centre is %.1f mm off the wheel axis (sideways motion per radian turned)", 1e3 * c) + pm;
      break;
    case MotionTarget::kHeading:
      if (mf == MotionFeature::kAbsDth) return fmt("the robot turns %.2f %% further to the left of what the model says, in turns either way", 1e2 * c) + pm;
      if (mf == MotionFeature::kW2) return fmt("the robot turns %.2f %% ", 1e2 * std::abs(c)) + more + " per rad/s of turn rate" + pm;
      if (mf == MotionFeature::kDs || mf == MotionFeature::kAbsDs) return fmt("the heading drifts %.2f mrad per m of travel", 1e3 * c) + pm;
      break;
    default: break;
  }
  return target() + " += " + fmt("%.4g", c) + " x " + name() + " (" + effects::motionTargetUnit(mt) + " per " +
         effects::motionFeatureUnit(mf) + ")" + pm;
}

std::string withToken(const Term& t) {
  switch (t.kind) {
    case Term::Kind::kMotion: return "feature:" + t.name() + "@" + t.target();
    case Term::Kind::kBeam: return "feature:" + t.name();
    default: return "";
  }
}

}  // namespace odoerr::sim::diag
