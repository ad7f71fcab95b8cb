// Encoder driver: wrap-safe deltas through 0xFFFF and 0xFFFFFFFF, impossible jumps rejected
// and counted, read errors counted.
#include <gtest/gtest.h>

#include "odoerr/drivers/encoder.hpp"

using namespace odoerr;

TEST(WrapDelta, SixteenBitThroughZero) {
  EXPECT_EQ(drivers::wrapDelta(0x0005, 0xFFFB, 16), 10);
  EXPECT_EQ(drivers::wrapDelta(0xFFFB, 0x0005, 16), -10);
  EXPECT_EQ(drivers::wrapDelta(0x7FFF, 0x0000, 16), 32767);
  EXPECT_EQ(drivers::wrapDelta(0x8000, 0x0000, 16), -32768);  // half a period: ambiguous, negative
  // Upper bits beyond the counter width are ignored.
  EXPECT_EQ(drivers::wrapDelta(0xABCD0005u, 0x1234FFFBu, 16), 10);
}

TEST(WrapDelta, ThirtyTwoBitThroughZero) {
  EXPECT_EQ(drivers::wrapDelta(0x00000004u, 0xFFFFFFFCu, 32), 8);
  EXPECT_EQ(drivers::wrapDelta(0xFFFFFFFCu, 0x00000004u, 32), -8);
}

namespace {
struct Rig {
  explicit Rig(std::uint8_t bits) : counter(bits), drv(counter, drivers::EncoderConfig{10000, 4}) {}
  hal::FakeEncoderCounter counter;
  drivers::EncoderDriver drv;
};
}  // namespace

TEST(EncoderDriver, AccumulatesAcrossManyWraps16) {
  Rig r(16);
  std::uint64_t raw = 0xFF00;  // start near the wrap
  r.counter.set(raw);
  ASSERT_EQ(r.drv.start(0), hal::Status::kOk);
  std::int64_t total = 0;
  for (int k = 1; k <= 2000; ++k) {  // 10 ms steps, 90 ticks each: 180000 ticks, 2.7 wraps
    raw += 90;
    r.counter.set(raw);
    std::int32_t d = 0;
    ASSERT_EQ(r.drv.sample(std::uint64_t(k) * 10000, &d), hal::Status::kOk) << k;
    total += d;
  }
  EXPECT_EQ(total, 180000);
  EXPECT_EQ(r.drv.counters().jumps_rejected, 0u);
}

TEST(EncoderDriver, BackwardsThroughWrap32) {
  Rig r(32);
  std::uint64_t raw = 40;
  r.counter.set(raw);
  ASSERT_EQ(r.drv.start(0), hal::Status::kOk);
  std::int64_t total = 0;
  for (int k = 1; k <= 10; ++k) {
    raw = (raw - 9) & 0xFFFFFFFFull;  // 90 ticks backwards through 0xFFFFFFFF
    r.counter.set(raw);
    std::int32_t d = 0;
    ASSERT_EQ(r.drv.sample(std::uint64_t(k) * 1000, &d), hal::Status::kOk);
    total += d;
  }
  EXPECT_EQ(total, -90);
}

TEST(EncoderDriver, ImpossibleJumpIsRejectedAndCounted) {
  Rig r(16);
  r.counter.set(1000);
  ASSERT_EQ(r.drv.start(0), hal::Status::kOk);
  std::int32_t d = 0;
  r.counter.set(1100);  // 100 ticks in 10 ms: limit 10000 * 0.01 + 4 = 104: fine
  EXPECT_EQ(r.drv.sample(10000, &d), hal::Status::kOk);
  EXPECT_EQ(d, 100);
  r.counter.set(1100 + 5000);  // a glitch: 5000 ticks in 10 ms
  EXPECT_EQ(r.drv.sample(20000, &d), hal::Status::kOutOfRange);
  EXPECT_EQ(d, 0) << "a rejected jump is never integrated";
  EXPECT_EQ(r.drv.counters().jumps_rejected, 1u);
  r.counter.set(1100 + 5000 + 50);  // the reference resynchronised: next sample is normal
  EXPECT_EQ(r.drv.sample(30000, &d), hal::Status::kOk);
  EXPECT_EQ(d, 50);
}

TEST(EncoderDriver, ReadErrorsAreCountedAndDoNotMoveTheReference) {
  Rig r(16);
  r.counter.set(10);
  ASSERT_EQ(r.drv.start(0), hal::Status::kOk);
  r.counter.fail(hal::Status::kInternal);
  std::int32_t d = 7;
  EXPECT_EQ(r.drv.sample(1000, &d), hal::Status::kInternal);
  EXPECT_EQ(d, 0);
  EXPECT_EQ(r.drv.counters().read_errors, 1u);
  r.counter.set(20);
  EXPECT_EQ(r.drv.sample(2000, &d), hal::Status::kOk);
  EXPECT_EQ(d, 10);
  EXPECT_EQ(r.drv.sample(3000, &d), hal::Status::kOk);
  EXPECT_EQ(d, 0);
}

TEST(EncoderDriver, SampleBeforeStartIsRefused) {
  Rig r(32);
  std::int32_t d = 0;
  EXPECT_EQ(r.drv.sample(0, &d), hal::Status::kFailedPrecondition);
}
