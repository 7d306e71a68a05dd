#include "common.hpp"

namespace tendyn::py {

void expose_tendon_bench(nb::module_& m) { (void)m; }

}  // namespace tendyn::py
