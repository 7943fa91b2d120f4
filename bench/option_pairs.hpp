#pragma once
// The `--name value` command lines of the benchmark programs.

#include <cstdio>
#include <functional>
#include <map>
#include <string>

namespace potmap::bench {

using OptionSetters = std::map<std::string, std::function<void(const std::string&)>>;

// Hands each value to its name's setter, in command-line order; false, after saying so on
// stderr, at a name it does not know. A last name without a value is left to the caller.
inline bool parse_option_pairs(int argc, char** argv, const char* program,
                               const OptionSetters& setters) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const auto it = setters.find(argv[i]);
    if (it == setters.end()) {
      std::fprintf(stderr, "%s: unknown option %s\n", program, argv[i]);
      return false;
    }
    it->second(argv[i + 1]);
  }
  return true;
}

}  // namespace potmap::bench
