// A float's bits as an integer, for checks that compare values bit for bit (NaN, -0
// and denormals included), which == on floats cannot.
#pragma once

#include <cstdint>
#include <cstring>

namespace test_support {

inline uint32_t float_bits(float v) {
  uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  return b;
}

}  // namespace test_support
