// Picks a reader by file name.
#include <algorithm>

#include "potmap/error.hpp"
#include "potmap/scan.hpp"

namespace potmap {

Dataset read_velodyne_dataset(const std::string& path, std::size_t fields, double max_range);

namespace {
bool ends_with(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}
}  // namespace

Dataset read_dataset(const std::string& path) {
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(), ::tolower);
  std::string base = lower;
  if (ends_with(base, ".gz")) base.resize(base.size() - 3);
  if (ends_with(base, ".bin")) {
    const bool nus = lower.find("nuscenes") != std::string::npos;
    return read_velodyne_dataset(path, nus ? 5 : 4, nus ? 110 : 120);
  }
  if (ends_with(base, ".npz")) {
    LabelledPoints lp = read_npz_labelled(path);
    Dataset ds;
    ds.scans = scans_from_labelled(lp);
    return ds;
  }
  // TODO(lead, after the io merge): `.csv` -> scans_from_labelled(read_labelled_csv(path)).
  // read_labelled_csv is implemented on the io branch; calling it here would break this branch's
  // link until then.
  if (ends_with(base, ".csv"))
    throw InputError(path + ": byte 0: labelled CSV needs read_labelled_csv (io branch)");
  return read_carmen(path);
}

}  // namespace potmap
