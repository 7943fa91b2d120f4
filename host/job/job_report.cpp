#include "job_report.hpp"

#include <chrono>
#include <filesystem>

#include "job_text.hpp"

namespace potmap::job {

experiment::DefaultDictionaryNotes dictionary_notes(const Report& report) {
  experiment::DefaultDictionaryNotes notes;
  notes.note = [report](const std::string& line) { report.note(line); };
  notes.start_progress = [report] {
    const auto t0 = std::chrono::steady_clock::now();
    return std::function<void(double)>([report, t0](double f) {
      report.progress({"dictionary", "share", std::size_t(f * 1000), 1000, seconds_since(t0), {}});
    });
  };
  return notes;
}

void write_scores(const std::string& dir, nlohmann::json summary, MappingJobResult& out) {
  const std::string scores = (std::filesystem::path(dir) / "scores.json").string();
  out.files.push_back(scores);
  summary["files"] = out.files;
  out.scores_json = summary.dump(1);
  write_text_atomically(scores, out.scores_json + "\n");
}

}  // namespace potmap::job
