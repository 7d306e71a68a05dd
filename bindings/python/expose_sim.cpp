#include "common.hpp"

namespace tendyn::py {

void expose_sim(nb::module_& m) { (void)m; }

}  // namespace tendyn::py
