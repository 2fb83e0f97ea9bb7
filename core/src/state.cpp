#include "ccfr/core/state.hpp"

namespace ccfr {

void SimState::resize(Index n) {
  const auto s = static_cast<size_t>(n);
  x.assign(s, Vec3::Zero());
  x_prev.assign(s, Vec3::Zero());
  v.assign(s, Vec3::Zero());
  rest.assign(s, Vec3::Zero());
  mass.assign(s, 0.0);
  inv_mass.assign(s, 0.0);
}

}  // namespace ccfr
