// Helpers for calling the shared device code directly on the host (the same text the
// OpenCL kernel compiles), in the generic instantiation with every feature compiled in.
#pragma once

#include <twinray/device/code.hpp>

namespace test {

template <class T>
using Code = twinray::device::Code<T>;
template <class T>
using K = typename Code<T>::template Kernel<TR_F_ALL>;
template <class T>
using vec3 = glm::vec<3, T>;

template <class T>
typename Code<T>::Ray make_ray(vec3<T> o, vec3<T> d) {
  typename Code<T>::Ray r;
  r.o = o;
  r.d = d;
  return r;
}

template <class T>
typename Code<T>::Hit no_hit() {
  return K<T>::tr_no_hit();
}

}  // namespace test
