#include "job_report.hpp"

#include <filesystem>

#include "job_text.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/default_dictionary_file.hpp"
#include "potmap/pot/dictionary_io.hpp"

namespace potmap::job {

Dictionary job_dictionary(const MappingJobOptions& options, const Report& report, int dim,
                          std::string* where) {
  *where = options.dictionary;
  if (!options.dictionary.empty()) return read_dictionary(options.dictionary);
  if (report.hooks.default_dictionary) return report.hooks.default_dictionary(dim, where);
  *where = default_dictionary_path(dim);
  std::error_code ec;
  if (where->empty() || !std::filesystem::exists(*where, ec))
    throw ArgumentError("mapping: no dictionary given, and the built-in " + std::to_string(dim) +
                        "D one is not built yet" + (where->empty() ? "" : " (" + *where + ")") +
                        ": build it once with `potmap dict default" + (dim == 3 ? " --3d" : "") +
                        "`, or give a .potdict file");
  return read_dictionary(*where);
}

void write_scores(const std::string& dir, nlohmann::json summary, MappingJobResult& out) {
  const std::string scores = (std::filesystem::path(dir) / "scores.json").string();
  out.files.push_back(scores);
  summary["files"] = out.files;
  out.scores_json = summary.dump(1);
  write_text_atomically(scores, out.scores_json + "\n");
}

}  // namespace potmap::job
