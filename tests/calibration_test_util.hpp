// Calibrations for the calibration store's tests (test_calibration_store.cpp, and the
// STM32F405 flash store's in test_stm32_drivers.cpp): a record with every entry set, and a
// field-by-field, bit-exact comparison.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>

#include "odoerr/drivers/calibration_store.hpp"

namespace odoerr::test {

inline std::uint32_t bitsOf(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

/// Field-by-field, bit-exact comparison (no memcmp: the struct may have padding).
inline ::testing::AssertionResult same(const drivers::Calibration& a, const drivers::Calibration& b) {
  if (a.drive != b.drive || a.count != b.count) {
    return ::testing::AssertionFailure() << "drive/count differ: " << int(a.drive) << "/"
                                         << int(a.count) << " vs " << int(b.drive) << "/"
                                         << int(b.count);
  }
  for (std::size_t i = 0; i < drivers::Calibration::kMaxParams; ++i) {
    if (bitsOf(a.value[i]) != bitsOf(b.value[i]) ||
        bitsOf(a.variance[i]) != bitsOf(b.variance[i])) {
      return ::testing::AssertionFailure() << "entry " << i << " differs";
    }
  }
  return ::testing::AssertionSuccess();
}

/// All eight entries set, from `base`.
inline drivers::Calibration makeCal(std::uint8_t drive, float base) {
  drivers::Calibration c{};
  c.drive = drive;
  c.count = 8;
  for (std::size_t i = 0; i < drivers::Calibration::kMaxParams; ++i) {
    c.value[i] = base + 0.125f * static_cast<float>(i);
    c.variance[i] = 1.0e-4f * static_cast<float>(i + 1) + base * 1.0e-6f;
  }
  return c;
}

}  // namespace odoerr::test
