#include "potmap/experiments/recording.hpp"

#include <chrono>

#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/dictionary_io.hpp"

namespace potmap::experiment {

std::vector<Scan> read_recording(const std::string& path, double range_cut, std::size_t first,
                                 std::size_t max_scans) {
  Dataset ds = read_dataset(path);
  if (ds.scans.empty()) throw InputError(path + ": no scans");
  if (first >= ds.scans.size())
    throw ArgumentError("first " + std::to_string(first) + " but " + path + " has " +
                        std::to_string(ds.scans.size()) + " scans");
  std::vector<Scan> scans(ds.scans.begin() + static_cast<long>(first), ds.scans.end());
  if (max_scans > 0 && scans.size() > max_scans) scans.resize(max_scans);
  if (range_cut > 0)
    for (Scan& s : scans) s = limit_range(s, range_cut);
  return scans;
}

RecordingMap map_recording(Context* ctx, const std::string& path, const RecordingOptions& o,
                           const DefaultDictionaryNotes& notes) {
  if (is_drive(path))
    throw ArgumentError("map_recording: " + path +
                        " is a 3D drive: map it with DriveMapper (potmap.map_drive, `potmap "
                        "mapping`)");
  const std::vector<Scan> scans = read_recording(path, o.range_cut, o.first, o.max_scans);
  RecordingMap r;
  r.dictionary = o.dictionary;
  auto dict = std::make_shared<const Dictionary>(
      o.dictionary.empty() ? default_dictionary(scans.front().dim, &r.dictionary, notes)
                           : read_dictionary(o.dictionary));
  if (scans.front().dim != dict->dim)
    throw ArgumentError("map_recording: " + path + " holds " + std::to_string(scans.front().dim) +
                        "D scans, the dictionary " + r.dictionary + " is " +
                        std::to_string(dict->dim) + "D");
  r.atoms = dict->size();
  r.mapper = std::make_shared<Mapper>(ctx, dict, o.mapper);
  const auto t0 = std::chrono::steady_clock::now();
  MapRunTotals totals;
  totals.test.dim = dict->dim;
  map_scored(ctx, *r.mapper, scans, totals);
  r.summary = summarise_run(ctx, *r.mapper, totals);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace potmap::experiment
