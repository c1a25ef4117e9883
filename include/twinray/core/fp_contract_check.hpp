// Run-time check that this translation unit was compiled without floating-point
// contraction (-ffp-contract=off, which the twinray CMake targets carry). With
// contraction, g++ fuses a*b+c into an FMA whenever FMA is available (-march=native,
// any AArch64), and the CPU image then differs from the OpenCL one in ~49% of pixels
// (docs/architecture.md, "Bitwise parity").
#pragma once

namespace twinray {

// True when a*a + c was fused: a = 1 + 2^-12, c = -(1 + 2^-11) gives exactly 2^-24
// fused and 0 unfused (a*a = 1 + 2^-11 + 2^-24 rounds to 1 + 2^-11 in float).
inline bool fp_contraction_detected() {
  volatile float va = 1.0f + 1.0f / 4096.0f;
  volatile float vc = -(1.0f + 1.0f / 2048.0f);
  float a = va, c = vc;
  float r = a * a + c;
  return r != 0.0f;
}

}  // namespace twinray
