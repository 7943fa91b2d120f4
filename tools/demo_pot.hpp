#pragma once
// The POT demo behind `potmap demo`: a dictionary from one built-in simulated town, another
// town mapped with it by POT and RePOT, scored on held-out beams, pictures written.
#include <string>

namespace potmap::cli {

struct PotDemoArgs {
  std::string source = "town1", target = "town2";
  std::size_t source_scans = 10, target_scans = 40;
  double spacing = 2.5;  ///< metres between target scans
  int rotations = 8;
  std::string method = "both";  ///< pot, repot or both
  bool map_defaults = true;     ///< potmap map's settings (false: the library's, the paper's)
  std::string out;              ///< output prefix (default out/demo/pot)
  std::string json;
  double res = 0;  ///< picture metres per pixel; 0: 1200 pixels along the long side
};

int run_pot_demo(const PotDemoArgs& a, const std::string& device);

}  // namespace potmap::cli
