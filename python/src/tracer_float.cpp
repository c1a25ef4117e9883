// NativeTracer in float, in a translation unit of its own so that the two precisions
// compile in parallel.
#include "native_tracer.hpp"

namespace twinray_python {
void bind_tracer_float(nb::module_& m) {
  bind_tracer<float>(m, "TracerFloat");
}
}  // namespace twinray_python
