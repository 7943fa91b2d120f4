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

void report_lookahead(const Scores& all, const Scores& beyond, double ms, std::size_t count,
                      const char* unit, const Report& report, nlohmann::json& j,
                      MappingJobResult& out) {
  out.lookahead = all;
  out.lookahead_beyond = beyond;
  auto json = [](const Scores& s) {
    return nlohmann::json{{"auc", s.auc}, {"nll", s.nll}, {"n", s.n}};
  };
  j["lookahead"] = {{"all", json(all)}, {"beyond_reach", json(beyond)}};
  j[std::string("lookahead_ms_per_") + unit] = ms / double(std::max<std::size_t>(count, 1));
  report.note(
      format("look-ahead     AUC %.4f  NLL %.4f  (%zu held-out samples scored before "
             "their %s); beyond every earlier sample's reach AUC %.4f  NLL %.4f  (%zu)",
             all.auc, all.nll, all.n, unit, beyond.auc, beyond.nll, beyond.n));
}

}  // namespace potmap::job
