#pragma once
// A Context on the test device with one tuning given in words and no tuning file, for the tests
// that check results do not depend on the tuning.
#include <memory>
#include <string>

#include "potmap/runtime/context.hpp"
#include "test_support.hpp"

namespace potmap::test {

inline std::unique_ptr<Context> tuned_context(const std::string& tuning) {
  ContextOptions co;
  co.device = context().info().name;
  co.tuning_file = false;
  co.tuning = tuning;
  return std::make_unique<Context>(co);
}

}  // namespace potmap::test
