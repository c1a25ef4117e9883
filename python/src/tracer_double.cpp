// NativeTracer in double (see tracer_float.cpp).
#include "native_tracer.hpp"

namespace twinray_python {
void bind_tracer_double(nb::module_& m) {
  bind_tracer<double>(m, "TracerDouble");
}
}  // namespace twinray_python
